"""Sweep tables: success rate versus noise per task (markdown, CSV, PNG), learning curves of the
online methods, and ``summary.md``; every file written atomically."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from poir_mjx.atomic import atomic_write_text
from poir_mjx.eval.artifacts import cell_hash, cell_path, read_cell
from poir_mjx.eval.baseline_report import write_baseline_curves
from poir_mjx.eval.methods import get_method
from poir_mjx.eval.stats import wilson_interval
from poir_mjx.eval.sweep_config import SweepConfig, base_config


def collect(cfg: SweepConfig, out: Path, task: str, digest: str) -> dict:
    table = {}
    for mname in cfg.methods:
        chash = cell_hash(cfg, task, mname, digest)
        for si in cfg.sigma_init:
            for sa in cfg.sigma_action:
                recs = [read_cell(cell_path(out, task, mname, si, sa, s), chash) for s in cfg.seeds]
                recs = [r for r in recs if r]
                if recs:
                    k = sum(r["successes"] for r in recs)
                    n = sum(r["episodes"] for r in recs)
                    table[(mname, si, sa)] = {"k": k, "n": n, "ci": wilson_interval(k, n), "data": recs[0]["data"],
                                              "diverged": sum(r["diverged"] for r in recs),
                                              "simulator": recs[0].get("simulator", "MJX")}  # fmt: skip
    return table


def _col(si, sa, cfg):
    return f"σ_init {si:g}" + (f", σ_act {sa:g}" if len(cfg.sigma_action) > 1 or sa else "")


def write_tables(cfg: SweepConfig, out: Path, digests: dict[str, str]) -> str:
    """Tables and plots of the cells made with the demo data whose content digest is `digests[task]`."""
    import matplotlib

    matplotlib.use("Agg")
    sections = []
    for task in cfg.tasks:
        table = collect(cfg, out, task, digests[task])
        if table:
            sections.append(_write_task(cfg, out, task, table, digests[task]))
    summary = "\n".join([f"# Sweep {cfg.name}", "", "Config:", "", "```json",
                         json.dumps(dataclasses.asdict(cfg), indent=2), "```", ""] + sections)  # fmt: skip
    atomic_write_text(out / "summary.md", summary)
    return summary


def _write_task(cfg: SweepConfig, out: Path, task: str, table: dict, digest: str) -> str:
    """<task>.md, .csv and .png (and the online learning curves); returns the task's section of summary.md."""
    md_text, csv_text = _task_table(cfg, task, table)
    atomic_write_text(out / f"{task}.md", md_text)
    atomic_write_text(out / f"{task}.csv", csv_text)
    _plot_task(cfg, task, table, out / f"{task}.png")
    section = md_text + f"\n![{task}]({task}.png)\n"
    extra = ""
    curves = write_learning_curves(cfg, out, task, digest)
    if curves:
        extra += "\n" + curves
        section += "\n" + curves + f"\n![{task} online]({task}-online.png)\n"
    base = write_baseline_curves(cfg, out, task, digest, _col)
    if base:
        extra += "\n" + base
        section += "\n" + base + f"\n![{task} baselines]({task}-baselines.png)\n"
    if extra:
        atomic_write_text(out / f"{task}.md", md_text + extra)
    return section


def _data_source(data: dict) -> str:
    if data.get("source") == "scripted expert":
        return (f"scripted expert ({data.get('expert', '?')}, {data.get('simulator', '?')}, "
                f"{data.get('num_demos', '?')} demos)")
    return f"robomimic file {data.get('path')}"


def _task_table(cfg: SweepConfig, task: str, table: dict) -> tuple[str, str]:
    """(markdown, CSV) of one task: a row per method, a column per (sigma_init, sigma_action) cell."""
    first = next(iter(table.values()))
    cols = [(si, sa) for si in cfg.sigma_init for sa in cfg.sigma_action]
    md = [f"## {task}", "", f"Success rate (Wilson 95% interval), {cfg.episodes} episodes x {len(cfg.seeds)} seed(s) "
          f"per cell, {cfg.max_steps} steps per episode, preset {cfg.preset}. "
          f"Expert data: {_data_source(first['data'])}. Simulator: {first['simulator']}.", "",
          "| method | " + " | ".join(_col(si, sa, cfg) for si, sa in cols) + " |",
          "|---|" + "---|" * len(cols)]  # fmt: skip
    csv = ["method," + ",".join(f"si={si:g} sa={sa:g} {x}" for si, sa in cols for x in ("rate", "lo", "hi"))]
    for m in cfg.methods:
        cells, row = [], []
        for si, sa in cols:
            c = table.get((m, si, sa))
            if c is None:
                cells.append("-"), row.extend(["", "", ""])
            else:
                div = f" ({c['diverged']} diverged)" if c["diverged"] else ""
                cells.append(f"{c['k'] / c['n']:.2f} [{c['ci'][0]:.2f}, {c['ci'][1]:.2f}]{div}")
                row.extend([f"{c['k'] / c['n']:.4f}", f"{c['ci'][0]:.4f}", f"{c['ci'][1]:.4f}"])
        md.append(f"| {m} | " + " | ".join(cells) + " |")
        csv.append(m + "," + ",".join(row))
    versus = _versus_table(cfg, table, cols) + _versus_table(cfg, table, cols, "POIR-random", _ranks)
    return "\n".join(md) + "\n" + versus, "\n".join(csv) + "\n"


def _ranks(name: str) -> bool:
    """A method whose planner ranks its trajectories by a reward (what POIR-random leaves out)."""
    m = get_method(name)
    return m.act == "plan" and m.selection == "top_k" and m.use_prior


def _versus_table(cfg: SweepConfig, table: dict, cols: list, reference: str = "EBC", which=lambda m: True) -> str:
    """Each method's (those `which` keeps) successes minus the reference's on the same (paired) episodes, with
    the two-sided Fisher exact p of the two counts; empty without the reference or another method."""
    others = [m for m in cfg.methods if m != reference and which(m)]
    if reference not in cfg.methods or not others:
        return ""
    from poir_mjx.eval.episodes import agreement_p_value

    what = {"POIR-random": " (the reward's ranking against random selection of the same planner's trajectories)"}
    md = ["", f"Versus {reference} on the same episodes{what.get(reference, '')}: difference in successes "
          "(two-sided Fisher exact p).", "",
          "| method | " + " | ".join(_col(si, sa, cfg) for si, sa in cols) + " |", "|---|" + "---|" * len(cols)]
    for m in others:
        cells = []
        for si, sa in cols:
            c, r = table.get((m, si, sa)), table.get((reference, si, sa))
            if c is None or r is None:
                cells.append("-")
            else:
                cells.append(f"{c['k'] - r['k']:+d} (p {agreement_p_value(c['k'], c['n'], r['k'], r['n']):.2g})")
        md.append(f"| {m} | " + " | ".join(cells) + " |")
    return "\n".join(md) + "\n"


def _plot_task(cfg: SweepConfig, task: str, table: dict, path: Path) -> None:
    """Success rate versus sigma_init with Wilson intervals, a line per method (and sigma_action)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3.5))
    for m in cfg.methods:
        for sa in cfg.sigma_action:
            xs = [si for si in cfg.sigma_init if (m, si, sa) in table]
            if not xs:
                continue
            cells = [table[(m, si, sa)] for si in xs]
            ys = [c["k"] / c["n"] for c in cells]
            err = np.array([[y - c["ci"][0], c["ci"][1] - y] for c, y in zip(cells, ys)]).T
            err = np.maximum(err, 0.0)
            label = m if len(cfg.sigma_action) == 1 else f"{m} σ_act {sa:g}"
            ax.errorbar(xs, ys, yerr=err, marker="o", capsize=3, label=label)
    ax.set_xlabel("σ_init (initial joint noise)")
    ax.set_ylabel("success rate")
    ax.set_ylim(-0.05, 1.05)
    ax.set_title(f"{task} ({cfg.preset})")
    ax.legend(fontsize=8)
    save_png(fig, path)


def write_learning_curves(cfg: SweepConfig, out: Path, task: str, digest: str) -> str:
    """Markdown table and `<task>-online.png` of the online methods' curves ("" if there are none)."""
    import matplotlib.pyplot as plt

    rows, lines = [], []
    for m in (m for m in cfg.methods if get_method(m).online):
        chash = cell_hash(cfg, task, m, digest)
        for si in cfg.sigma_init:
            for sa in cfg.sigma_action:
                recs = [read_cell(cell_path(out, task, m, si, sa, s), chash) for s in cfg.seeds]
                recs = [r for r in recs if r]
                if not recs:
                    continue
                steps = [c["env_steps"] for c in recs[0]["curve"]]
                k = np.sum([[c["successes"] for c in r["curve"]] for r in recs], 0)
                n = np.sum([[c["episodes"] for c in r["curve"]] for r in recs], 0)
                r_steps = [x["env_steps"] for x in recs[0]["rounds"]]
                err = np.mean([[x["wm_error"] for x in r["rounds"]] for r in recs], 0)
                err_off = np.mean([[x["wm_error_offline"] for x in r["rounds"]] for r in recs], 0)
                label = f"{m}, {_col(si, sa, cfg)}"
                lines.append((label, steps, k / n, r_steps, err, err_off))
                rows.append(f"| {label} | " + "; ".join(f"{int(x):,}: {a}/{b}" for x, a, b in zip(steps, k, n))
                            + f" | {err[0]:.3g} → {err[-1]:.3g} (offline model {err_off[-1]:.3g}) |")  # fmt: skip
    if not rows:
        return ""
    oc = get_method(next(m for m in cfg.methods if get_method(m).online)).agent_config(base_config(cfg)).online
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
