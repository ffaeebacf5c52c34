"""``demos generate`` (make demos), ``demos success`` (make expert-success) and ``demos spread``: the scripted expert's
commands."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import jax
import numpy as np

from poir_mjx.atomic import atomic_write_text
from poir_mjx.compat import x64_enabled
from poir_mjx.core.config import ConfigError
from poir_mjx.data import expert as ex
from poir_mjx.data.demos import generate
from poir_mjx.data.expert_episodes import EXPERT_STEPS
from poir_mjx.envs.tasks import float32_square_note
from poir_mjx.eval.expert_success import mjx_partial_path, mjx_success, robosuite_success
from poir_mjx.options import DemosGenerate, DemosSpread, DemosSuccess
from poir_mjx.versions import command_line


def set_precision(x64: bool, tasks, simulators) -> None:
    """--x64 turns jax_enable_x64 on before any array exists (off, a JAX_ENABLE_X64 from the environment stands);
    a note on stderr when NutAssemblySquare would run in MJX in float32, where the expert's grasp often fails."""
    if x64:
        jax.config.update("jax_enable_x64", True)
    note = float32_square_note(tasks, simulators, x64_enabled(), "--x64")
    if note:
        print(note, file=sys.stderr)


def run_generate(opts: DemosGenerate) -> int:
    if opts.num <= 0 or opts.batch <= 0:
        raise ConfigError(f"--num and --batch: must be positive, got {opts.num} and {opts.batch}")
    if not (np.isfinite(opts.sigma_init) and opts.sigma_init >= 0):
        raise ConfigError(f"--sigma-init: must be finite and >= 0, got {opts.sigma_init}")
    if Path(opts.out).exists() and not Path(opts.out).is_dir():
        raise ConfigError(f"--out: {opts.out} is a file, expected a folder for the HDF5 files")
    set_precision(opts.x64, opts.tasks, (opts.simulator,))
    for task in opts.tasks:
        generate(task, opts.num, opts.seed, opts.sigma_init, opts.out, simulator=opts.simulator, batch=opts.batch,
                 style=opts.demo_style)  # fmt: skip
    return 0


def run_success(opts: DemosSuccess) -> int:
    if opts.episodes <= 0 or opts.batch < 0:
        raise ConfigError(f"--episodes and --batch: must be positive (--batch 0: all at once), got {opts.episodes} and {opts.batch}")
    if opts.physics != "reference" and "mjx" not in opts.simulator:
        raise ConfigError(f"--physics: {opts.physics!r} sets MJX's physics; --simulator {' '.join(opts.simulator)} "
                          "does not step MJX")  # fmt: skip
    set_precision(opts.x64, opts.tasks, opts.simulator)
    rows, partials = [], []
    for task in opts.tasks:
        for sim in opts.simulator:
            if sim == "mjx":
                partials.append(mjx_partial_path(opts.out / ".partial", task, opts.episodes, opts.seed, opts.sigma_init,
                                                 EXPERT_STEPS[task], x64=x64_enabled(), physics=opts.physics))  # fmt: skip
                r = mjx_success(task, opts.episodes, opts.seed, opts.sigma_init, batch=opts.batch, partial=partials[-1],
                                progress=True, physics=opts.physics)  # fmt: skip
            else:
                r = robosuite_success(task, opts.episodes, opts.seed, opts.sigma_init)
            rows.append({"task": task, **r})
            print(f"{task} {sim}: {r['successes']}/{r['episodes']}", flush=True)
    dev = jax.devices()[0]
    lines = [
        "# Scripted expert: success rate",
        "",
        "Length: robosuite, the recorded demo (the episode stops 4 steps after the first success); "
        "MJX, the step of first success.",
        "",
        f"Expert: {ex.NAME}; sigma_init {opts.sigma_init}, no action noise, seed {opts.seed}; "
        f"JAX device {dev.platform} (x64 {jax.config.jax_enable_x64}); MJX physics {opts.physics}. "
        f"Command: `{command_line()}`.",
        "",
        "| task | simulator | episodes | successes | success rate | diverged | mean length of successful episodes | wall s |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        ln = f"{r['length_mean']:.0f}" if r["length_mean"] is not None else "-"
        lines.append(f"| {r['task']} | {r['simulator']} | {r['episodes']} | {r['successes']} | "
                     f"{r['successes'] / r['episodes']:.2f} | {r['diverged']} | {ln} | {r['seconds']:.0f} |")  # fmt: skip
    table = "\n".join(lines) + "\n"
    tag = opts.tag
    atomic_write_text(opts.out / f"success_{tag}.md", table)
    atomic_write_text(opts.out / f"success_{tag}.json", json.dumps(rows, indent=2) + "\n")
    for p in partials:  # their outcomes are in the tables now
        p.unlink(missing_ok=True)
    print(table)
    return 0


def run_spread(opts: DemosSpread) -> int:
    """The demo sets' action spread side by side, printed (and written to --out with its numbers as JSON)."""
    from poir_mjx.data.spread import file_spread, spread_table

    if not opts.data:
        raise ConfigError("--data: give at least one robomimic HDF5 file")
    rows = [file_spread(p) for p in opts.data]
    table = spread_table(rows)
    if opts.out is not None:
        atomic_write_text(opts.out, f"# Action spread of demo sets\n\nCommand: `{command_line()}`.\n\n{table}")
        atomic_write_text(opts.out.with_suffix(".json"), json.dumps(rows, indent=2) + "\n")
    print(table)
    return 0


def run_compact(opts) -> int:
    """Each file's compact copy, checked to give the same transitions (content digest) as its source."""
    from poir_mjx.data.compact import compact
    from poir_mjx.data.robomimic import DatasetError, read_transitions
    from poir_mjx.sweep.artifacts import transitions_digest

    for src in opts.data:
        dst = compact(src, Path(opts.out) / Path(src).name)
        before, after = transitions_digest(read_transitions(src)), transitions_digest(read_transitions(dst))
        if before != after:
            dst.unlink()
            raise DatasetError(f"{src}: its compact copy reads as other transitions (digest {after}, not {before})")
        print(f"wrote {dst}: {dst.stat().st_size / 1e6:.1f} MB (from {Path(src).stat().st_size / 1e6:.1f} MB), "
              f"the same transitions (digest {after})")
    return 0
