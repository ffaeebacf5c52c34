"""The functions behind ``sweep``, ``compare``, ``report`` and ``envs`` (``eval``: evaluate.py)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from poir_mjx import options
from poir_mjx.flags import dotted
from poir_mjx.core.config import apply_overrides


def with_flags(cfg, flags: dict):
    """The sweep config with the command line's POIR fields added to its overrides (a flag wins)."""
    if not flags:
        return cfg
    from poir_mjx.sweep.config import base_config

    apply_overrides(base_config(cfg), flags, source="command line")  # a bad value: one line naming the field
    return dataclasses.replace(cfg, overrides={**cfg.overrides, **flags})


def sweep(opts: options.Sweep) -> int:
    from poir_mjx.devices import select_device
    from poir_mjx.sweep.run import load_sweep_config, run_sweep

    cfg = with_flags(load_sweep_config(opts.config), dotted(opts.poir))
    import jax

    select_device(cfg.device, f"{opts.config}: field 'device'")
    jax.config.update("jax_enable_x64", cfg.x64)  # before any array exists
    out = run_sweep(cfg, opts.results, opts.data, opts.checkpoints, replace_config=opts.replace_config)
    print((out / "summary.md").read_text())
    print(f"sweep {cfg.name}: tables in {out}/ (summary.md, <task>.md/.csv/.png)")
    return 0


def compare(opts: options.Compare) -> int:
    from poir_mjx.sweep.compare import main as compare_main

    return compare_main(list(opts.runs), opts.out, opts.versus, opts.methods)


def report(opts: options.Report) -> int:
    from poir_mjx.sweep.index import report as write_report

    return write_report(opts.results, opts.out, opts.check, opts.tables)


def envs(opts: options.Envs) -> int:
    """Export the tasks' models and metadata, and the assets they reference, to `opts.out`."""
    from poir_mjx.atomic import atomic_write_bytes, atomic_write_text
    from poir_mjx.envs.export import asset_files, export_task, referenced_assets
    from poir_mjx.envs.tasks import ASSETS_DIR, TASKS, task_files

    out, xmls = Path(opts.out), []
    for task in opts.task or TASKS:
        files = task_files(task, out)
        if opts.check and files.xml.exists() and files.meta.exists():
            xmls.append(files.xml.read_text())
            continue
        xml, meta = export_task(task)
        atomic_write_text(files.xml, xml)
        atomic_write_text(files.meta, meta)
        xmls.append(xml)
        print(f"wrote {files.xml} and {files.meta}")
    missing = [r for x in xmls for r in referenced_assets(x) if not (out / r).exists()]
    if not opts.check or missing or not (out / ASSETS_DIR / "LICENSE-robosuite").exists():
        for rel, data in asset_files(xmls).items():
            atomic_write_bytes(out / rel, data)
        print(f"wrote {out / ASSETS_DIR}/ (meshes referenced by the models, robosuite's licence)")
    return 0
