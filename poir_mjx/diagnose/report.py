"""The forensics page: every diagnosed cell of a task, mechanism by mechanism, from the episode records alone
(``<out>/<task>.md``, ``<out>/<task>.json`` with the same numbers, ``<out>/<task>-shares.png``)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from poir_mjx.atomic import atomic_write_text
from poir_mjx.core.config import REWARDS
from poir_mjx.diagnose import rankings
from poir_mjx.diagnose.names import ACTION_NAMES, by_group, observation_names


def load_cells(out: Path, task: str) -> dict[tuple[str, str], list[dict]]:
    """{(method, cell folder name): episode records} under <out>/<task>/."""
    cells: dict[tuple[str, str], list[dict]] = {}
    for path in sorted((Path(out) / task).glob("*/*/episode=*.json")):
        rec = json.loads(path.read_text())
        cells.setdefault((path.parent.parent.name, path.parent.name), []).append(rec)
    return cells


def summarize(recs: list[dict], task: str) -> dict:
    """One cell's figures, averaged over its planner calls (episodes pooled)."""
    names, groups = observation_names(task)
    calls = [c for r in recs for c in r["calls"]]
    first = recs[0]
    s: dict = {"episodes": len(recs), "successes": sum(r["success_step"] > 0 for r in recs), "calls": len(calls),
               "sigma_init": first["sigma_init"], "seed": first["seed"], "K": first["ensemble_size"],
               "N": first["num_trajectories"], "top_k": first["top_k"], "oracle": first["oracle"],
               "plan_ebc_distance": _mean(c["plan_ebc_distance"] for c in calls),
               "gripper_sign_differs_from_ebc": _mean(c["gripper"]["sign_differs_from_ebc"] for c in calls),
               "gripper_at_bound": _mean(c["gripper"]["at_bound"] for c in calls),
               "provenance": [r["provenance"] for r in recs if r.get("provenance")]}  # fmt: skip
    for r in REWARDS:
        x = [c[r] for c in calls]
        s[r] = {"between_head_share": _mean(v["between_head_share"] for v in x),
                "one_head_top_k": _mean(float(v["one_head"]) for v in x)}  # fmt: skip
        if first["oracle"]:
            for f in ("spearman", "spearman_within_head", "top_k_overlap", "true_between_head_share",
                      "true_gain_model_top_k", "true_gain_oracle_top_k"):  # fmt: skip
                s[r][f] = _mean(v[f] for v in x if f in v)  # records before a field was added lack it
        dims = names if r != "dril" else ACTION_NAMES
        share = np.mean([c["shares"][r] for c in calls], 0)
        s[r]["shares"] = dict(zip(dims, share.tolist()))
        if r != "dril":
            s[r]["group_shares"] = by_group(share, groups)
    if first["oracle"] and all("rankings" in c for c in calls):
        s["rankings"] = rankings.summarize([r["calls"] for r in recs])
    demo = recs[0]["demos"]
    s["one_step_sq_error"] = {
        "demos": by_group(demo["error"], groups, np.mean),
        "expert_change": by_group(demo["change"], groups, np.mean),
        "episodes": by_group(np.mean([r["episode_one_step_sq_error"] for r in recs], 0), groups, np.mean),
        **({"candidates": by_group(np.mean([c["one_step_sq_error"] for c in calls], 0), groups, np.mean)}
           if first["oracle"] else {}),
        **{name: by_group(demo[f"holdout_{name}_error"], groups, np.mean)
           for name in ("training", "held_out") if f"holdout_{name}_error" in demo},
    }  # fmt: skip
    return s


def _mean(xs) -> float:
    v = [float(x) for x in xs]
    v = [x for x in v if np.isfinite(x)]
    return float(np.mean(v)) if v else float("nan")


def write_page(out: Path, task: str) -> Path:
    cells = load_cells(out, task)
    summary = {f"{m} {c}": summarize(recs, task) for (m, c), recs in cells.items()}
    atomic_write_text(Path(out) / f"{task}.json", json.dumps(summary, indent=1) + "\n")
    page = Path(out) / f"{task}.md"
    atomic_write_text(page, render(task, summary))
    if summary:
        _plot(Path(out) / f"{task}-shares.png", summary)
    return page


def provenance_line(summary: dict) -> str:
    """Where the records came from: each field's distinct values over every record of every cell, in order (cells
    diagnosed by several commands, or on several machines, name all of them)."""
    provs = [p for s in summary.values() for p in s["provenance"]]
    if not provs:
        return ""

    def values(f) -> str:
        return "; ".join(dict.fromkeys(f(p) for p in provs))

    def demos(p) -> str:
        return f"{p['demos'].get('source')} (sha256 {p['demos'].get('sha256')})"

    commands = list(dict.fromkeys(f"`{p['command']}`" for p in provs))
    return (f"Simulator: {values(lambda p: p['simulator'])}; machine: {values(lambda p: p['machine'])}; "
            f"demos: {values(demos)}; command{'s' if len(commands) > 1 else ''}: {'; '.join(commands)}.")


def render(task: str, summary: dict) -> str:
    lines = [f"# Planner forensics: {task}", "",
             "Written by `python -m poir_mjx.cli diagnose` from the episode records beside this page: each cell's "
             "episodes re-run in robosuite with the cell's keys (no action noise), the planner taken apart every "
             "`every` steps. Every reward scores the same candidates (the planner's own reward only ranks them).", ""]  # fmt: skip
    if not summary:
        return "\n".join(lines + ["No diagnosed cells yet.", ""])
    cols = list(summary)
    if line := provenance_line(summary):
        lines += [line, ""]
    lines += ["## Cells", "", _table(["", *cols], [
        ["episodes (successes)", *[f"{s['episodes']} ({s['successes']})" for s in summary.values()]],
        ["planner calls", *[str(s["calls"]) for s in summary.values()]],
        ["K, N, top-k", *[f"{s['K']}, {s['N']}, {s['top_k']}" for s in summary.values()]],
        ["|plan - EBC| (env units)", *[f"{s['plan_ebc_distance']:.3f}" for s in summary.values()]]])]
    lines += ["", "## 1. Head lottery: does the return say which head, or which noise?", "",
              "Between-head share: the share of the returns' variance explained by the head a trajectory used "
              "(0: none, 1: all). One head: calls whose top-k all come from one head.", ""]  # fmt: skip
    rows = []
    for r in REWARDS:
        rows.append([f"{r.upper()} between-head share (model)", *[_f(s[r]["between_head_share"]) for s in summary.values()]])
        if any(s["oracle"] for s in summary.values()):
            rows.append([f"{r.upper()} between-head share (true)", *[_f(s[r].get("true_between_head_share")) for s in summary.values()]])
        rows.append([f"{r.upper()} top-k from one head", *[_pct(s[r]["one_head_top_k"]) for s in summary.values()]])
    lines += [_table(["", *cols], rows)]
    if any(s["oracle"] for s in summary.values()):
        lines += ["", "## Oracle: the same candidates in the true simulator", "",
                  "Spearman: rank correlation of the world model's returns with the true ones (robosuite, same "
                  "actions, same start); within a head: among one head's trajectories, averaged over the heads. "
                  "Overlap: |model top-k ∩ true top-k| / k (chance: k/N). Gain: the true "
                  "return of the model's top-k (and of the true top-k) above the candidates' mean: what ranking by "
                  "the model buys, against what any ranking could.", ""]  # fmt: skip
        rows = []
        for r in REWARDS:
            for f, label in (("spearman", "Spearman"), ("spearman_within_head", "Spearman within a head"),
                             ("top_k_overlap", "top-k overlap"),
                             ("true_gain_model_top_k", "true gain, model top-k"),
                             ("true_gain_oracle_top_k", "true gain, true top-k")):  # fmt: skip
                rows.append([f"{r.upper()} {label}", *[_f(s[r].get(f)) for s in summary.values()]])
        lines += [_table(["", *cols], rows)]
    lines += rankings.render(summary)
    lines += ["", "## 2. Reward geometry: which dimensions each reward measures", "",
              "Share of the squared distance behind each reward (L2: to the nearest expert state; DRIL: between the "
              "most distant pair of BC heads, action dimensions; MOREL: between the most distant pair of world "
              "models), over every candidate state of every call.", ""]  # fmt: skip
    for r in REWARDS:
        key = "shares" if r == "dril" else "group_shares"
        dims = list(next(iter(summary.values()))[r][key])
        lines += [f"**{r.upper()}**", "", _table(["", *cols], [[d, *[_pct(s[r][key][d]) for s in summary.values()]]
                                                          for d in dims]), ""]  # fmt: skip
    lines += ["## 3. Gripper noise", "",
              _table(["", *cols], [
                  ["candidates whose gripper sign differs from EBC's", *[_pct(s["gripper_sign_differs_from_ebc"]) for s in summary.values()]],
                  ["candidates at the gripper bound (|a| >= 1)", *[_pct(s["gripper_at_bound"]) for s in summary.values()]]]),
              "", "## 4. World-model one-step error (normalised units², mean per dimension of each group)", "",
              "Demos: the expert transitions it was trained on; training / held_out: a world model trained "
              "on all but the held-out demos (`--holdout`), on its own training demos and on the held-out ones; episodes: the diagnosed episodes' own transitions; "
              "candidates: the first imagined step against robosuite's; expert change: the expert's own one-step "
              "change, the size of what the actions move.", ""]  # fmt: skip
    groups = list(next(iter(summary.values()))["one_step_sq_error"]["demos"])
    rows = []
    for where in ("expert_change", "demos", "training", "held_out", "episodes", "candidates"):
        if all(where in s["one_step_sq_error"] for s in summary.values()):
            for g in groups:
                rows.append([f"{where}: {g}", *[_f(s["one_step_sq_error"][where][g]) for s in summary.values()]])
    lines += [_table(["", *cols], rows), ""]
    return "\n".join(lines)


def _table(header, rows) -> str:
    return "\n".join(["| " + " | ".join(header) + " |", "|" + "---|" * len(header)] +
                     ["| " + " | ".join(r) + " |" for r in rows])  # fmt: skip


def _f(x) -> str:
    return "n/a" if x is None or not np.isfinite(x) else f"{x:.3g}"


def _pct(x) -> str:
    return "n/a" if x is None or not np.isfinite(x) else f"{100 * x:.0f}%"


def _plot(path: Path, summary: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    width = 0.8 / len(summary)
    for ax, r, key in zip(axes, REWARDS, ("group_shares", "shares", "group_shares")):
        dims = list(next(iter(summary.values()))[r][key])
        for i, (name, s) in enumerate(summary.items()):
            ax.bar(np.arange(len(dims)) + i * width, [s[r][key][d] for d in dims], width, label=name)
        ax.set_xticks(np.arange(len(dims)) + 0.4 - width / 2, dims, rotation=45, ha="right", fontsize=8)
        ax.set_title(f"{r.upper()}: share of the reward's squared distance")
        ax.set_ylim(0, 1)
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=90)
    plt.close(fig)
    tmp.replace(path)
