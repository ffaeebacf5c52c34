"""The ``gpu-check`` subcommand: refuse a run without a GPU (one line), else run the stages."""

from __future__ import annotations

from poir_mjx.options import GpuCheck


def run(opts: GpuCheck) -> int:
    from poir_mjx.devices import select_device
    from poir_mjx.gpucheck.runner import run_all, run_stage

    if opts.dry_run:
        select_device("cpu", "gpu-check --dry-run")
    else:  # --only too: a stage at GPU sizes never runs on a CPU
        select_device("gpu", "gpu-check (--dry-run for the CPU)")
    if opts.only is not None:
        run_stage(opts.only, opts.dry_run, opts.out, opts.scratch, opts.demos)
        return 0
    return run_all(opts.out, opts.scratch, opts.dry_run, opts.stages, opts.demos)
