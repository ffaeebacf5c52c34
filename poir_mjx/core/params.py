"""POIR's parameter and result types, and the check every training loop runs on its losses."""

from __future__ import annotations

from typing import Any

import jax
import numpy as np
from flax import struct

from poir_mjx.core.normalizer import Normalizer


class TrainingDivergedError(ValueError):
    """A training loss became NaN or inf: the run stops with one line and records nothing."""


def check_losses(metrics: dict, where: str, hint: str = "train.learning_rate") -> None:
    """Raise TrainingDivergedError naming `where` if any metric whose name contains "loss" is not finite (every
    training loop's losses: POIR's ensembles, online fine-tuning, the baselines)."""
    for name, value in metrics.items():
        if "loss" in name and not np.all(np.isfinite(np.asarray(value))):
            raise TrainingDivergedError(f"{where}: the training loss {name!r} is not finite; nothing was recorded "
                                        f"(lower {hint})")  # fmt: skip


@struct.dataclass
class POIRParams:
    bc: Any  # stacked BC ensemble [K]
    wm: Any  # stacked world-model ensemble [K] (None for policy-only agents)
    reward_wm: Any  # world model used by the MOREL reward (a frozen offline copy during fine-tuning)
    obs_norm: Normalizer
    act_norm: Normalizer
    expert_states: jax.Array  # normalised expert states searched by the L2 reward [E, ds]
    dril_level: jax.Array  # the expert data's own DRIL disagreement at planner.disagreement_quantile, []
    morel_level: jax.Array  # the same for MOREL's reward model on the expert transitions (0 without one), []


@struct.dataclass
class Imagined:
    """One planner call's imagined trajectories in the [K, M] head layout (normalised spaces)."""

    returns: jax.Array  # [K, M], -inf on padding cells (n >= N)
    actions: jax.Array  # [H, K, M, da] the candidate actions, step by step (actions[0]: the first actions)
    states: jax.Array  # [H + 1, K, M, ds] the real state, then the world model's predictions
    step_rewards: jax.Array  # [H, K, M] the imitation reward of each step
