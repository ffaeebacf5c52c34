"""Names of the observation and action dimensions and the groups the forensics report them by."""

from __future__ import annotations

import json

import numpy as np

from poir_mjx.envs.layout import ROBOT_OBS, object_key_group
from poir_mjx.envs.tasks import task_files

ACTION_NAMES = ("pos.x", "pos.y", "pos.z", "rot.x", "rot.y", "rot.z", "gripper")
_AXES = {3: ("x", "y", "z"), 4: ("x", "y", "z", "w"), 2: ("0", "1")}


def observation_names(task: str) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(name, group) of every dimension of `task`'s observation vector, e.g. ("eef_pos.x", "eef_pos")."""
    meta = json.loads(task_files(task).meta.read_text())
    keys = [(k.removeprefix("robot0_"), n) for k, n, _ in ROBOT_OBS]
    keys += [(k, object_key_group(k)[0]) for k in meta["object_obs_keys"]]
    names = [f"{k}.{a}" for k, n in keys for a in _AXES[n]]
    groups = [k for k, n in keys for _ in range(n)]
    return tuple(names), tuple(groups)


def by_group(values: np.ndarray, groups: tuple[str, ...], reduce=np.sum) -> dict[str, float]:
    """Per-dimension values gathered by group (in first-seen order)."""
    values = np.asarray(values, np.float64)
    out: dict[str, float] = {}
    for g in dict.fromkeys(groups):
        out[g] = float(reduce(values[[i for i, x in enumerate(groups) if x == g]]))
    return out
