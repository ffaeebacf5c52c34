"""One table across sweep runs (ablations): ``python -m poir_mjx.cli compare results/cpu-ablate-* --out F``.

Each row is a (run, method): the run's config overrides and demonstration files, then the success
rate and Wilson interval per (task, sigma_init, sigma_action) cell, read from the run's cell
records made with the run's recorded config (each cell's config hash checked: stale cells are left out and
counted). Runs with the same grid, episodes and seeds
share their episode keys, so their rows are paired comparisons.
"""

from __future__ import annotations

import json
from pathlib import Path

from poir_mjx.atomic import atomic_write_text
from poir_mjx.core.config import ConfigError
from poir_mjx.eval.stats import wilson_interval


def _read_run(run: Path) -> tuple[dict, list[dict]]:
    """(recorded sweep config, the cell records made with it) of a run folder: a cell whose config hash is
    not the one this config gives now (a stale cell, left by an earlier config or version) is left out."""
    from poir_mjx.sweep.artifacts import cell_hash
    from poir_mjx.sweep.records import load_record, read_cell
    from poir_mjx.sweep.config import SweepConfig
    from poir_mjx.sweep.run_folder import upgrade_recorded

    cfg_path = run / "config.json"
    if not cfg_path.is_file():
        raise ConfigError(f"{cfg_path}: no such file (not a sweep run folder, or made before run folders recorded their config)")
    try:
        raw = json.loads(cfg_path.read_bytes().decode("utf-8"))
        if not isinstance(raw, dict):
            raise ConfigError(f"{cfg_path}: not a sweep config (expected a JSON object, got {type(raw).__name__})")
        raw = upgrade_recorded(raw)
        cfg = SweepConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in raw.items()})
    except ConfigError:
        raise
    except (OSError, ValueError, TypeError, RecursionError) as e:
        raise ConfigError(f"{cfg_path}: not a sweep config of this version ({type(e).__name__})") from None
    recs, stale = [], 0
    for f in sorted((run / "cells").rglob("*.json")):
        rec = load_record(f)
        if rec is None or "successes" not in rec:
            raise ConfigError(f"{f}: not a cell record")
        data = rec.get("data") if isinstance(rec.get("data"), dict) else {}
        task, method = rec.get("task", ""), rec.get("method", "")
        if task not in cfg.tasks or method not in cfg.methods:
            stale += 1
            continue
        chash = cell_hash(cfg, task, method, str(data.get("sha256", "")))
        if read_cell(f, chash, {"episodes": cfg.episodes, "task": task, "method": method}) is None:
            stale += 1
            continue
        recs.append(rec)
    if not recs:
        why = f"{stale} stale cell(s) only (made with another config or version); rerun the sweep" if stale else "run the sweep first"
        raise ConfigError(f"{run}/cells: no cell records of its config.json; {why}")
    if stale:
        print(f"{run}: {stale} stale cell record(s) left out (made with another config or version)")
    return raw, recs


def compare(runs: list[Path]) -> str:
    rows, cols = [], []
    for run in runs:
        cfg, recs = _read_run(run)
        by_method: dict[str, dict] = {}
        for rec in recs:
            col = (rec["task"], rec["sigma_init"], rec["sigma_action"])
            if col not in cols:
                cols.append(col)
            cell = by_method.setdefault(rec["method"], {}).setdefault(col, [0, 0])
            cell[0] += rec["successes"]
            cell[1] += rec["episodes"]
        changed = {**cfg.get("overrides", {}), **{f"demo_files.{t}": f for t, f in cfg.get("demo_files", {}).items()}}
        overrides = ", ".join(f"{k}={v}" for k, v in sorted(changed.items())) or "-"
        for method, cells in by_method.items():
            rows.append((run.name, overrides, method, cells))
    cols.sort()
    head = "| run | overrides | method | " + " | ".join(f"{t} σ_init {si:g}" + (f" σ_act {sa:g}" if sa else "") for t, si, sa in cols) + " |"
    lines = [head, "|---|---|---|" + "---|" * len(cols)]
    for name, overrides, method, cells in rows:
        out = []
        for col in cols:
            if col not in cells:
                out.append("-")
                continue
            k, n = cells[col]
            lo, hi = wilson_interval(k, n)
            out.append(f"{k}/{n} = {k / n:.2f} [{lo:.2f}, {hi:.2f}]")
        lines.append(f"| {name} | {overrides} | {method} | " + " | ".join(out) + " |")
    return "\n".join(lines) + "\n"


def main(runs: list[Path], out: Path | None) -> int:
    text = compare(runs)
    print(text, end="")
    if out is not None:
        atomic_write_text(out, text)
        print(f"wrote {out}")
    return 0
