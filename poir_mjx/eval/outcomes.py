"""How each episode ended, read from the observations the robosuite evaluator already gathers (no extra simulation).

A success rate says how many episodes failed, not how. Every robosuite episode on the low-dim observation is
labelled when it ends, from the hand's and the object's positions in its observations:

- ``success``: the task's own success check fired (the episode stops there);
- ``diverged``: the physics stopped being finite;
- ``ran_away``: at the end the hand is more than RAN_AWAY_M from the object (the arm left the object behind);
- ``stalled_at_object``: the hand ends within AT_OBJECT_M of the object and has moved less than REST_M over the
  last REST_STEPS steps (it stopped at the object without completing the task: a fixed point of the policy);
- ``stalled_elsewhere``: at rest the same way, between AT_OBJECT_M and RAN_AWAY_M from the object;
- ``moving_near_object``: still moving within RAN_AWAY_M of the object when the episode ran out.

``moved_object`` counts the failed episodes in which the object was pushed more than TOUCH_M sideways or raised
more than TOUCH_M above where it started (not lowered: robosuite drops Lift's cube about 1 cm onto the table in the
first steps). Records made on 2026-12-06 before this rule carry ``touched`` instead, which counted that settling
drop as a move; it is not shown.
The object-state observation (``observation: object``) has no hand position: its episodes are not labelled.
"""

from __future__ import annotations

import json

import numpy as np

from poir_mjx.envs.layout import ROBOT_OBS, ROBOT_OBS_SIZE, object_key_group
from poir_mjx.envs.tasks import task_files

OUTCOMES = ("success", "diverged", "ran_away", "stalled_at_object", "stalled_elsewhere", "moving_near_object")
RAN_AWAY_M = 0.30
AT_OBJECT_M = 0.05
REST_M = 0.01
REST_STEPS = 50
TOUCH_M = 0.01


def position_slices(task: str, observation: str = "low_dim") -> tuple[slice, slice] | None:
    """(hand, object) position slices of `task`'s observation vector, or None where it has no hand position."""
    if observation != "low_dim":
        return None
    meta = json.loads(task_files(task).meta.read_text())
    hand = next(i for i, (k, _, _) in enumerate(ROBOT_OBS) if k == "robot0_eef_pos")
    start = sum(n for _, n, _ in ROBOT_OBS[:hand])
    offset = ROBOT_OBS_SIZE
    for key in meta["object_obs_keys"]:
        n, _ = object_key_group(key)
        if key.endswith("_pos") and "_to_" not in key and not key.startswith("gripper"):
            return slice(start, start + 3), slice(offset, offset + 3)
        offset += n
    raise ValueError(f"{task}: no object position among its object observations {meta['object_obs_keys']}")


class OutcomeTracker:
    """Follows n episodes' hand and object positions step by step; ``labels`` names how each ended."""

    def __init__(self, n: int, slices: tuple[slice, slice]):
        self.hand_at, self.obj_at = slices
        self.start = np.zeros((n, 3))
        self.hand = np.zeros((n, 3))
        self.obj = np.zeros((n, 3))
        self.moved = np.zeros(n)  # the object's largest sideways move or rise from its start so far
        self.recent = np.zeros((n, REST_STEPS, 3))  # the hand's last REST_STEPS positions (a ring)
        self.count = np.zeros(n, np.int64)

    def begin(self, rows: np.ndarray, obs: np.ndarray) -> None:
        """The episodes `rows` start from observations `obs` [len(rows), d]."""
        self.start[rows] = obs[:, self.obj_at]
        self.count[rows] = 0
        self.moved[rows] = 0.0
        self.observe(rows, obs)

    def observe(self, rows: np.ndarray, obs: np.ndarray) -> None:
        """The episodes `rows` reached observations `obs` (one step)."""
        self.hand[rows], self.obj[rows] = obs[:, self.hand_at], obs[:, self.obj_at]
        d = self.obj[rows] - self.start[rows]
        self.moved[rows] = np.maximum(self.moved[rows], np.maximum(np.linalg.norm(d[:, :2], axis=1), d[:, 2]))
        self.recent[rows, self.count[rows] % REST_STEPS] = self.hand[rows]
        self.count[rows] += 1

    def labels(self, first_success: np.ndarray, diverged: np.ndarray) -> tuple[list[str], np.ndarray]:
        """(the outcome of each episode, OUTCOMES' names; whether a failed episode moved its object)."""
        dist = np.linalg.norm(self.hand - self.obj, axis=1)
        window = np.minimum(self.count, REST_STEPS)
        spread = np.array([np.linalg.norm(self.recent[i, :w] - self.hand[i], axis=1).max() if w else 0.0
                           for i, w in enumerate(window)])  # fmt: skip
        at_rest = (self.count >= REST_STEPS) & (spread < REST_M)
        out = np.where(dist > RAN_AWAY_M, "ran_away",
                       np.where(at_rest, np.where(dist < AT_OBJECT_M, "stalled_at_object", "stalled_elsewhere"),
                                "moving_near_object"))  # fmt: skip
        out = np.where(np.asarray(diverged, bool), "diverged", out)
        out = np.where(np.asarray(first_success) >= 0, "success", out)
        moved = (out != "success") & (self.moved > TOUCH_M)
        return [str(x) for x in out], moved


def summary(labels: list[str], moved) -> dict:
    """A cell record's ``outcomes``: the count of each outcome, and of failed episodes that moved the object."""
    return {**{k: labels.count(k) for k in OUTCOMES}, "moved_object": int(np.sum(moved))}
