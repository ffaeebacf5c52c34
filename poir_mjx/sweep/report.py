"""Sweep tables: success rate versus noise per task (markdown, CSV, PNG), learning curves of the
online methods, and ``summary.md``; every file written atomically."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from poir_mjx.atomic import atomic_write_text
from poir_mjx.sweep.curves import save_png, write_baseline_curves, write_learning_curves
from poir_mjx.eval.methods import get_method
from poir_mjx.eval.stats import wilson_interval
from poir_mjx.sweep.config import SweepConfig
from poir_mjx.sweep.outcome_table import outcome_table, summed
from poir_mjx.sweep.plan import SweepPlan, noise_label


def collect(plan: SweepPlan, task: str) -> dict:
    """(method, sigma_init, sigma_action) -> successes, episodes, Wilson interval, data and simulator of the cell's
    current records (summed over the seeds)."""
    table = {}
    for mname, si, sa, recs in plan.results(task):
        k = sum(r["successes"] for r in recs)
        n = sum(r["episodes"] for r in recs)
        table[(mname, si, sa)] = {"k": k, "n": n, "ci": wilson_interval(k, n), "data": recs[0]["data"],
                                  "diverged": sum(r["diverged"] for r in recs),
                                  "simulator": recs[0].get("simulator", "MJX"), "outcomes": summed(recs)}  # fmt: skip
    return table


def write_tables(plan: SweepPlan) -> str:
    """Tables and plots of the plan's current cells (made with its config and each task's expert data)."""
    import matplotlib

    matplotlib.use("Agg")
    cfg, out, sections = plan.cfg, plan.out, []
    for task in cfg.tasks:
        table = collect(plan, task)
        if table:
            sections.append(_write_task(plan, task, table))
    summary = "\n".join([f"# Sweep {cfg.name}", "", "Config:", "", "```json",
                         json.dumps(dataclasses.asdict(cfg), indent=2), "```", ""] + sections)  # fmt: skip
    atomic_write_text(out / "summary.md", summary)
    return summary


def rewrite_tables(run: Path) -> bool:
    """Rewrite run folder `run`'s tables and plots from its cell records with this version's report code (nothing is
    simulated); False, writing nothing, when a task of the run has no current cell record (tables published without
    their cells stay as they are). The expert data's digest of each task is the one its cells record."""
    from poir_mjx.sweep.artifacts import recorded_provenance
    from poir_mjx.sweep.config import load_sweep_config

    cfg = load_sweep_config(Path(run) / "config.json", recorded=True)
    digests = {}
    for task in cfg.tasks:
        prov = next((p for m in cfg.methods for s in cfg.seeds if (p := recorded_provenance(Path(run), cfg, task, m, s))),
                    None)  # fmt: skip
        if prov is None:
            return False
        digests[task] = prov["sha256"]
    write_tables(SweepPlan.build(cfg, Path(run), digests))
    return True


def _write_task(plan: SweepPlan, task: str, table: dict) -> str:
    """<task>.md, .csv and .png (and the learning curves); returns the task's section of summary.md."""
    cfg, out = plan.cfg, plan.out
    md_text, csv_text = _task_table(cfg, task, table)
    atomic_write_text(out / f"{task}.md", md_text)
    atomic_write_text(out / f"{task}.csv", csv_text)
    _plot_task(cfg, task, table, out / f"{task}.png")
    section = md_text + f"\n![{task}]({task}.png)\n"
    extra = ""
    curves = write_learning_curves(plan, task)
    if curves:
        extra += "\n" + curves
        section += "\n" + curves + f"\n![{task} online]({task}-online.png)\n"
    base = write_baseline_curves(plan, task)
    if base:
        extra += "\n" + base
        section += "\n" + base + f"\n![{task} baselines]({task}-baselines.png)\n"
    if extra:
        atomic_write_text(out / f"{task}.md", md_text + extra)
    return section


def _data_source(data: dict) -> str:
    if data.get("source") == "scripted expert":
        style = ", human-like style (demo_style human_like)" if data.get("demo_style", "scripted") != "scripted" else ""
        si = data.get("sigma_init", 0.02)
        at = f", recorded at sigma_init {si:g}" if isinstance(si, (int, float)) and si != 0.02 else ""
        return (f"scripted expert ({data.get('expert', '?')}{style}, {data.get('simulator', '?')}, "
                f"{data.get('num_demos', '?')} demos{at})")
    return f"robomimic file {data.get('path')}"


def _task_table(cfg: SweepConfig, task: str, table: dict) -> tuple[str, str]:
    """(markdown, CSV) of one task: a row per method, a column per (sigma_init, sigma_action) cell."""
    first = next(iter(table.values()))
    cols = [(si, sa) for si in cfg.sigma_init for sa in cfg.sigma_action]
    md = [f"## {task}", "", f"Success rate (Wilson 95% interval), {cfg.episodes} episodes x {len(cfg.seeds)} seed(s) "
          f"per cell, {cfg.max_steps} steps per episode, preset {cfg.preset}. "
          f"Expert data: {_data_source(first['data'])}. Simulator: {first['simulator']}."
          + (f" Observation: {cfg.observation} (robosuite's object-state vector alone)." if cfg.observation == "object"
             else ""), "",
          "| method | " + " | ".join(noise_label(si, sa, cfg) for si, sa in cols) + " |",
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
    for m in (m for m in cfg.methods if get_method(m).online):  # an online method against its own offline agent
        versus += _versus_table(cfg, table, cols, m.removesuffix(" online"), lambda x, m=m: x == m)
    versus += outcome_table(cfg, table, cols)
    return "\n".join(md) + "\n" + versus, "\n".join(csv) + "\n"


def _ranks(name: str) -> bool:
    """A method whose planner ranks its trajectories by a reward (what POIR-random leaves out)."""
    m = get_method(name)
    return m.act == "plan" and m.selection != "random" and m.use_prior


def _versus_table(cfg: SweepConfig, table: dict, cols: list, reference: str = "EBC", which=lambda m: True) -> str:
    """Each method's (those `which` keeps) successes minus the reference's on the same (paired) episodes, with
    the two-sided Fisher exact p of the two counts; empty without the reference or another method."""
    others = [m for m in cfg.methods if m != reference and which(m)]
    if reference not in cfg.methods or not others:
        return ""
    from poir_mjx.eval.episodes import agreement_p_value
    from poir_mjx.eval.stats import pooled_p_value

    what = {"POIR-random": " (the reward's ranking against random selection of the same planner's trajectories)"}
    if reference.startswith("POIR-") and reference + " online" in others:
        what[reference] = " (after online fine-tuning against the offline agent it started from)"
    pool = len(cols) > 1
    md = ["", f"Versus {reference} on the same episodes{what.get(reference, '')}: difference in successes "
          "(two-sided Fisher exact p" + ("; all cells: the total difference and the Cochran-Mantel-Haenszel p over "
          "the cells both have" if pool else "") + ").", "",
          "| method | " + " | ".join(noise_label(si, sa, cfg) for si, sa in cols) + (" | all cells" if pool else "")
          + " |", "|---|" + "---|" * (len(cols) + pool)]  # fmt: skip
    for m in others:
        cells, both = [], []
        for si, sa in cols:
            c, r = table.get((m, si, sa)), table.get((reference, si, sa))
            if c is None or r is None:
                cells.append("-")
            else:
                cells.append(f"{c['k'] - r['k']:+d} (p {agreement_p_value(c['k'], c['n'], r['k'], r['n']):.2g})")
                both.append((c["k"], c["n"], r["k"], r["n"]))
        if pool:
            total = sum(k1 - k2 for k1, _, k2, _ in both)
            cells.append(f"{total:+d} (p {pooled_p_value(both):.2g})" if len(both) > 1 else "-")
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
