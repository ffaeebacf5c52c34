"""How widely a demo set's actions spread (``demos spread``): per action dimension, per demo, per gripper command.

A model learns only what its demos cover. For the robosuite OSC_POSE action (dx, dy, dz, rx, ry, rz, gripper),
``action_spread`` gives each dimension's std, the rotation actions' overall std (the root mean square of the three
dimensions' stds), the demos' length statistics and how the gripper commands are distributed (robosuite acts on
their sign only), and ``spread_table`` puts several demo sets side by side in one markdown table.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from poir_mjx.data.robomimic import ENV_NAMES, DatasetError, read_transitions

DIMS = ("dx", "dy", "dz", "rx", "ry", "rz", "gripper")


def action_spread(actions: np.ndarray, lengths: np.ndarray) -> dict:
    """The spread of `actions` [N, 7] (demos concatenated) whose demos are `lengths` [D] long."""
    a = np.asarray(actions, np.float64)
    lengths = np.asarray(lengths)
    std = a.std(0)
    g = a[:, 6]
    flips = [int((np.diff(np.sign(g[s : s + n])) != 0).sum()) for s, n in zip(np.cumsum(lengths) - lengths, lengths)]
    return {
        "demos": int(len(lengths)),
        "steps": int(a.shape[0]),
        "std": {d: float(s) for d, s in zip(DIMS, std)},
        "rotation_std": float(np.sqrt(np.mean(std[3:6] ** 2))),
        "length_mean": float(lengths.mean()),
        "length_std": float(lengths.std()),
        "length_min": int(lengths.min()),
        "length_max": int(lengths.max()),
        "gripper_close": float(np.mean(g > 0)),  # robosuite closes on a positive command
        "gripper_at_bounds": float(np.mean(np.abs(g) >= 1.0)),  # exactly -1 or +1
        "gripper_switches_per_demo": float(np.mean(flips)),
        "demos_with_regrasp": int(sum(f >= 3 for f in flips)),  # close, open, close again
    }


def file_spread(path: str | Path) -> dict:
    """``action_spread`` of a robomimic file's demos, with the file, its task (from env_args) and the expert's style
    from its generator record ("file" when it has none: e.g. a robomimic dataset)."""
    tr = read_transitions(path)  # one DatasetError naming the file and field for anything unreadable
    name = tr.env_args.get("env_name")
    task = next((t for t, n in ENV_NAMES.items() if n == name), None)
    if task is None:
        raise DatasetError(f"{path}: field env_args.env_name: {name!r} is not one of {', '.join(ENV_NAMES.values())}")
    gen = tr.provenance.get("poir_mjx_generator", {})
    gen = json.loads(gen) if isinstance(gen, str) else gen
    style = gen.get("demo_style", "scripted") if isinstance(gen, dict) and gen else "file"
    return {"path": str(path), "task": task, "style": style, **action_spread(tr.actions, tr.demo_lengths)}


def spread_table(rows: list[dict]) -> str:
    """One markdown table, a column per demo set (``file_spread`` rows), a row per statistic."""
    head = "| statistic | " + " | ".join(f"{Path(r['path']).name} ({r['task']}, {r['style']})" for r in rows) + " |"
    lines = [head, "|---|" + "---|" * len(rows)]
    stat_rows = [(f"std {d}", lambda r, d=d: f"{r['std'][d]:.3f}") for d in DIMS]
    stat_rows += [
        ("rotation std (rms of rx, ry, rz)", lambda r: f"{r['rotation_std']:.3f}"),
        ("demos", lambda r: str(r["demos"])),
        ("length mean ± std", lambda r: f"{r['length_mean']:.1f} ± {r['length_std']:.1f}"),
        ("length min-max", lambda r: f"{r['length_min']}-{r['length_max']}"),
        ("gripper: share of steps closing (> 0)", lambda r: f"{r['gripper_close']:.2f}"),
        ("gripper: share of commands at ±1", lambda r: f"{r['gripper_at_bounds']:.2f}"),
        ("gripper switches per demo", lambda r: f"{r['gripper_switches_per_demo']:.2f}"),
        ("demos with a re-grasp (≥ 3 switches)", lambda r: str(r["demos_with_regrasp"])),
    ]
    for name, fmt in stat_rows:
        lines.append(f"| {name} | " + " | ".join(fmt(r) for r in rows) + " |")
    return "\n".join(lines) + "\n"
