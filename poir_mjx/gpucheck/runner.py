"""Running the stages: priority order, a deadline each within the whole budget, finished ones skipped.

On a GPU every stage runs in a child process (``gpu-check --only STAGE``) that is stopped at its deadline;
what it wrote stays, and the next stage starts. The children share JAX's persistent compilation cache,
so a rerun, or the sweep stage after e2e, compiles nothing again. The dry run runs them in this
process (compiled programs shared in memory), at tiny sizes, on the CPU.
"""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from poir_mjx.atomic import atomic_write_text
from poir_mjx.gpucheck import record
from poir_mjx.gpucheck.sizes import DRY, GPU, STAGES, deadline


def run_stage(stage: str, dry_run: bool, out: Path, scratch: Path, demos: Path = Path(".gpu-demos")) -> None:
    from poir_mjx.gpucheck.stages import STAGE_FUNCTIONS, Where

    sizes = DRY if dry_run else GPU
    rec = record.Record(out, stage, dataclasses.asdict(sizes), dry_run)
    STAGE_FUNCTIONS[stage](sizes, rec, Where(scratch, demos))
    rec.done()


def stage_command(stage: str, out: Path, scratch: Path, demos: Path) -> list[str]:
    return [sys.executable, "-m", "poir_mjx.cli", "gpu-check", "--only", stage, "--out", str(out), "--scratch",
            str(scratch), "--demos", str(demos)]  # fmt: skip


def run_limited(cmd: list[str], limit: float) -> tuple[str, float]:
    """Run `cmd` in its own process group, the whole group stopped after `limit` seconds: (status, seconds)."""
    t0 = time.monotonic()
    proc = subprocess.Popen(cmd, start_new_session=True)
    try:
        rc = proc.wait(timeout=limit)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        return f"stopped at its deadline ({limit:.0f} s)", time.monotonic() - t0
    return ("complete" if rc == 0 else f"failed (exit status {rc})"), time.monotonic() - t0


def run_all(out: Path, scratch: Path, dry_run: bool, stages: tuple[str, ...] = STAGES,
            demos: Path = Path(".gpu-demos")) -> int:  # fmt: skip
    """Every stage in `stages` (priority order) not complete in `out` already; returns 1 if one failed."""
    sizes = DRY if dry_run else GPU
    out.mkdir(parents=True, exist_ok=True)
    start, status = time.monotonic(), {}
    for stage in [s for s in STAGES if s in stages]:
        prev = record.read(out, stage)
        same = prev is not None and prev.get("dry_run") == dry_run and prev.get("sizes") == _as_read(sizes)
        if same and prev.get("complete"):  # measured with these sizes already
            status[stage] = ("complete earlier", 0.0)
            continue
        left = sizes.budget_s - (time.monotonic() - start)
        if left < 10:
            status[stage] = ("not run: the budget was spent", 0.0)
            continue
        if dry_run:
            t0 = time.monotonic()
            run_stage(stage, True, out, scratch, demos)
            status[stage] = ("complete", time.monotonic() - t0)
        else:
            status[stage] = run_limited(stage_command(stage, out, scratch, demos), min(deadline(sizes, stage), left))
        print(f"gpu-check: {stage} {status[stage][0]} in {status[stage][1]:.0f} s", flush=True)
        write_summary(out, status, dry_run)
    write_summary(out, status, dry_run)
    return 1 if any(s.startswith("failed") for s, _ in status.values()) else 0


def _as_read(sizes) -> dict:
    """The sizes as a stage file stores them (tuples read back as lists)."""
    import json

    return json.loads(json.dumps(dataclasses.asdict(sizes)))


def write_summary(out: Path, status: dict, dry_run: bool) -> None:
    """``summary.md``: each stage's status and its rows as a table, from the stage files."""
    lines = [f"# GPU check{' (dry run: tiny sizes on the CPU)' if dry_run else ''}", ""]
    for stage in STAGES:
        data = record.read(out, stage)
        st, secs = status.get(stage, ("not run", 0.0))
        lines.append(f"## {stage}: {st}{f' in {secs:.0f} s' if secs else ''}")
        if data is None:
            lines.append("")
            continue
        m, c = data["machine"], data.get("compilations") or {}
        lines += ["", f"Device {m['device']} (driver {m['driver']}), {m['versions']}, matmul precision "
                      f"{m['matmul_precision']}, x64 {m['x64']}. Command: `{m['command']}`.", ""]  # fmt: skip
        if c:
            lines += [f"Compiled {c['programs']} programs: {c['backend_compile_s']:.0f} s in XLA, "
                      f"{c['trace_s']:.0f} s tracing, {c['lowering_s']:.0f} s lowering.", ""]  # fmt: skip
        rows = data["rows"]
        if rows:
            cols = list(rows[0])
            lines += ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
            lines += ["| " + " | ".join(_fmt(r.get(c)) for c in cols) + " |" for r in rows]
        lines.append("")
    atomic_write_text(out / "summary.md", "\n".join(lines) + "\n")


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return "-" if v is None else str(v)
