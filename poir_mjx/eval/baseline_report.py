"""The baselines' learning curves: success (MJX, the cell's evaluation episodes) and the method's own imitation reward
versus environment steps, a markdown table and ``<task>-baselines.png``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from poir_mjx.eval.artifacts import cell_hash, cell_path, read_cell
from poir_mjx.eval.methods import get_method
from poir_mjx.eval.sweep_config import SweepConfig


def write_baseline_curves(cfg: SweepConfig, out: Path, task: str, digest: str, col) -> str:
    """Markdown of the baselines' curves and their plot ("" if the sweep has no baseline cells yet).
    `col(si, sa, cfg)` names a noise cell as the tables do."""
    rows, lines = [], []
    for m in (m for m in cfg.methods if get_method(m).is_baseline):
        chash = cell_hash(cfg, task, m, digest)
        for si in cfg.sigma_init:
            for sa in cfg.sigma_action:
                recs = [r for r in (read_cell(cell_path(out, task, m, si, sa, s), chash) for s in cfg.seeds) if r]
                if not recs:
                    continue
                steps = [c["env_steps"] for c in recs[0]["curve"]]
                k = np.sum([[c["successes"] for c in r["curve"]] for r in recs], 0)
                n = np.sum([[c["episodes"] for c in r["curve"]] for r in recs], 0)
                rew = [_mean([r["curve"][i]["imitation_reward"] for r in recs]) for i in range(len(steps))]
                label = f"{m}, {col(si, sa, cfg)}"
                lines.append((label, steps, k / n, rew))
                rows.append(f"| {label} | " + "; ".join(f"{int(x):,}: {a}/{b}" for x, a, b in zip(steps, k, n))
                            + " | " + ", ".join("-" if np.isnan(r) else f"{r:.3g}" for r in rew) + " |")  # fmt: skip
    if not rows:
        return ""
    _plot(lines, task, cfg.preset, out / f"{task}-baselines.png")
    md = [f"### Baselines' training ({task})", "",
          "Successes of the deterministic policy over the cell's evaluation episodes in MJX (the training environment) "
          "versus environment steps of training, and the method's own imitation reward (mean over the training "
          "iterations since the previous evaluation). The tables' cells are the final policies in the sweep's "
          "simulator.", "", "| method, cell | env steps: successes/episodes | imitation reward |", "|---|---|---|"]  # fmt: skip
    return "\n".join(md + rows) + "\n"


def _mean(values) -> float:
    """Mean of the values that are not None (NaN when none: the step-0 evaluation has no training reward)."""
    vals = [v for v in values if v is not None and np.isfinite(v)]
    return float(np.mean(vals)) if vals else float("nan")


def _plot(lines, task: str, preset: str, path: Path) -> None:
    import matplotlib.pyplot as plt

    from poir_mjx.eval.report import label_curves, save_png

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 3.5))
    for label, steps, rate, rew in lines:
        ax.plot(steps, rate, marker="o", label=label)
        ax2.plot(steps[1:], rew[1:], marker=".", label=label)
    label_curves(ax, ax2, "success rate (MJX)", f"{task}: baselines ({preset})", "imitation reward")
    save_png(fig, path)
