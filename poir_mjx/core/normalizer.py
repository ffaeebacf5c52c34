"""Standardisation with the expert data's statistics, with a floor on each dimension's std.

POIR normalises observations and actions to mean 0 / std 1 with the expert data's statistics
(paper, section 4). Dimensions that barely move in the demonstrations (a cube's quaternion x/y:
std 0.0008; the hand's quaternion: 0.005-0.02) would then dominate every distance, prediction
error and disagreement as soon as the arm leaves the expert's support, which is where POIR acts:
a cube tilt of 0.05 is 61 std. So the std of each dimension is floored in environment units, per
observation group (position in metres, quaternion component, gripper finger joint in metres),
from the task's observation layout. One normaliser per agent serves the BC prior, the world
model and the rewards. Floors of 0 give the paper's behaviour (std as measured, 1e-6 at least).
"""

from __future__ import annotations

from typing import Sequence

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from poir_mjx.core.config import NormalizerConfig

EPS = 1e-6
GROUPS = ("position", "quaternion", "gripper")


@struct.dataclass
class Normalizer:
    """Mean/std normalisation (identity when disabled); float32 in and out."""

    mean: jax.Array
    std: jax.Array

    @staticmethod
    def fit(x: jax.Array, enabled: bool = True, floor=0.0) -> Normalizer:
        """Statistics of `x` [n, d]; `floor` (scalar or [d], env units) bounds each std from below."""
        x = jnp.asarray(x, jnp.float32)
        if not enabled:
            return Normalizer(jnp.zeros(x.shape[-1], jnp.float32), jnp.ones(x.shape[-1], jnp.float32))
        floor = jnp.broadcast_to(jnp.asarray(floor, jnp.float32), x.shape[-1:])
        return Normalizer(x.mean(0), jnp.maximum(jnp.maximum(x.std(0), floor), EPS))

    def _stats(self):
        return jnp.asarray(self.mean, jnp.float32), jnp.asarray(self.std, jnp.float32)

    def __call__(self, x):
        mean, std = self._stats()
        return (jnp.asarray(x, jnp.float32) - mean) / std

    def inverse(self, z):
        mean, std = self._stats()
        return jnp.asarray(z, jnp.float32) * std + mean


def observation_floor(cfg: NormalizerConfig, groups: Sequence[str] | None, size: int) -> np.ndarray:
    """Per-dimension std floor [size] from each dimension's group; no layout (None): no floor."""
    if groups is None:
        return np.zeros(size, np.float32)
    if len(groups) != size:
        raise ValueError(f"obs_groups: {len(groups)} entries for an observation of size {size}")
    per_group = {"position": cfg.position_std_floor, "quaternion": cfg.quaternion_std_floor,
                 "gripper": cfg.gripper_std_floor}  # fmt: skip
    unknown = sorted(set(groups) - set(per_group))
    if unknown:
        raise ValueError(f"obs_groups: unknown group(s) {unknown}; expected {GROUPS}")
    return np.array([per_group[g] for g in groups], np.float32)
