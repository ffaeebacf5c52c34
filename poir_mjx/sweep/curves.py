"""Learning curves of the methods that train in each noise cell, a markdown table and a PNG per task:
the online methods' success and world-model error versus environment steps (``<task>-online.png``), and the
baselines' success (MJX, the cell's evaluation episodes) and own imitation reward (``<task>-baselines.png``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from poir_mjx.eval.methods import get_method
from poir_mjx.sweep.plan import SweepPlan, noise_label


def write_baseline_curves(plan: SweepPlan, task: str) -> str:
    """Markdown of the baselines' curves and their plot ("" if the sweep has no baseline cells yet)."""
    cfg, out, rows, lines = plan.cfg, plan.out, [], []
    for m, si, sa, recs in plan.results(task, lambda m: get_method(m).is_baseline):
        steps, k, n = _success_curve(recs)
        label = f"{m}, {noise_label(si, sa, cfg)}"
        rew = [_mean([r["curve"][i]["imitation_reward"] for r in recs]) for i in range(len(steps))]
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


def _success_curve(recs: list[dict]) -> tuple[list[int], np.ndarray, np.ndarray]:
    """(environment steps, successes, episodes) of the records' learning curves, summed over the seeds."""
    steps = [c["env_steps"] for c in recs[0]["curve"]]
    k = np.sum([[c["successes"] for c in r["curve"]] for r in recs], 0)
    n = np.sum([[c["episodes"] for c in r["curve"]] for r in recs], 0)
    return steps, k, n


def _mean(values) -> float:
    """Mean of the values that are not None (NaN when none: the step-0 evaluation has no training reward)."""
    vals = [v for v in values if v is not None and np.isfinite(v)]
    return float(np.mean(vals)) if vals else float("nan")


def _plot(lines, task: str, preset: str, path: Path) -> None:
    import matplotlib.pyplot as plt

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 3.5))
    for label, steps, rate, rew in lines:
        ax.plot(steps, rate, marker="o", label=label)
        ax2.plot(steps[1:], rew[1:], marker=".", label=label)
    label_curves(ax, ax2, "success rate (MJX)", f"{task}: baselines ({preset})", "imitation reward")
    save_png(fig, path)


def write_learning_curves(plan: SweepPlan, task: str) -> str:
    """Markdown table and `<task>-online.png` of the online methods' curves ("" if there are none)."""
    import matplotlib.pyplot as plt

    cfg, out, rows, lines = plan.cfg, plan.out, [], []
    for m, si, sa, recs in plan.results(task, lambda m: get_method(m).online):
        steps, k, n = _success_curve(recs)
        label = f"{m}, {noise_label(si, sa, cfg)}"
        r_steps = [x["env_steps"] for x in recs[0]["rounds"]]
        err = np.mean([[x["wm_error"] for x in r["rounds"]] for r in recs], 0)
        err_off = np.mean([[x["wm_error_offline"] for x in r["rounds"]] for r in recs], 0)
        lines.append((label, steps, k / n, r_steps, err, err_off))
        rows.append(f"| {label} | " + "; ".join(f"{int(x):,}: {a}/{b}" for x, a, b in zip(steps, k, n))
                    + f" | {err[0]:.3g} → {err[-1]:.3g} (offline model {err_off[-1]:.3g}) |")  # fmt: skip
    if not rows:
        return ""
    oc = plan.method_config(next(m for m in cfg.methods if get_method(m).online)).online
    md = [f"### Online fine-tuning ({task})", "",
          f"Successes over the cell's evaluation episodes (the offline cell's episodes) versus environment steps "
          f"collected; {oc.num_envs} episodes per round, {oc.updates_per_env_step:g} world-model gradient step(s) per "
          f"environment step, online fraction {oc.mix_start:g} + {oc.mix_increment:g} every {oc.mix_every} steps up to "
          f"{oc.mix_max:g}. The last column is the world model's one-step error (normalised units) on each round's "
          f"new deployment transitions before training on them, first round → last round, and the frozen "
          f"offline model's error on the last round's data.", "",
          "| method, cell | env steps: successes/episodes | world-model error |", "|---|---|---|"]  # fmt: skip
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 3.5))
    for label, steps, rate, r_steps, err, err_off in lines:
        ax.plot(steps, rate, marker="o", label=label)
        (ln,) = ax2.plot(r_steps, err, marker=".", label=f"{label}: fine-tuned")
        ax2.plot(r_steps, err_off, linestyle="--", color=ln.get_color(), label=f"{label}: offline model")
    label_curves(ax, ax2, "success rate", f"{task}: online fine-tuning ({cfg.preset})",
                 "one-step error on new deployment data")
    ax2.set_yscale("log")
    save_png(fig, out / f"{task}-online.png")
    return "\n".join(md + rows) + "\n"


def label_curves(ax, ax2, success_label: str, title: str, right_label: str) -> None:
    """Axes of a learning-curve figure: success versus environment steps (left), a training quantity (right)."""
    ax.set_xlabel("environment steps")
    ax.set_ylabel(success_label)
    ax.set_ylim(-0.05, 1.05)
    ax.set_title(title)
    ax.legend(fontsize=7)
    ax2.set_xlabel("environment steps")
    ax2.set_ylabel(right_label)
    ax2.legend(fontsize=7)


def save_png(fig, path: Path) -> None:
    """Save and close a figure atomically (temporary name, then rename)."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    tmp.replace(path)
