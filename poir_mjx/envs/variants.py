"""Per-episode object sizes: robosuite's Lift draws its cube's half-sizes uniformly in [0.020, 0.022] m
per axis at every reset (it rebuilds its model); the exported model holds one draw.

A task whose metadata has ``object_size`` gets ``NUM_VARIANTS`` compiled models: variant 0 is the
exported size, the others are drawn from robosuite's range (fixed seed), each compiled by MuJoCo
with the box's mass and inertia at the task's density, so every derived field (body inertia,
subtree mass, invweight0, dof_M0, bounding radius) is MuJoCo's own. Only the MJX model leaves that
differ between variants are stacked; an episode picks its variant at reset and ``model(k)``
rebuilds the model with that variant's leaves (under ``vmap`` each episode has its own), as
mujoco_playground's domain randomisation does.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import mjx

NUM_VARIANTS = 16
SEED = 0


def variant_sizes(meta: dict, exported: np.ndarray, k: int = NUM_VARIANTS) -> np.ndarray:
    """[k, 3] half-sizes: the exported one first, then uniform draws in the task's range."""
    spec = meta["object_size"]
    rng = np.random.default_rng(SEED)
    draws = rng.uniform(spec["size_min"], spec["size_max"], (k - 1, 3))
    return np.concatenate([np.asarray(exported, np.float64)[None], draws])


def compile_variant(xml: str, meshdir: str, meta: dict, size: np.ndarray, edit=None) -> mujoco.MjModel:
    """The task's model with the object box's half-sizes `size` (mass and inertia from the density); `edit`, if
    given, further edits the spec (the environment's physics settings) before it is compiled."""
    spec = mujoco.MjSpec.from_string(xml)
    spec.meshdir = meshdir
    if edit is not None:
        edit(spec)
    o = meta["object_size"]
    spec.geom(o["geom"]).size[:3] = size
    body = spec.body(meta["object_body"])
    mass = o["density"] * 8.0 * float(np.prod(size))
    a, b, c = size
    body.mass = mass
    body.inertia[:] = mass / 3.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    return spec.compile()


@dataclasses.dataclass(frozen=True, eq=False)
class ModelVariants:
    """MJX models that differ only in some array leaves; ``model(k)`` is variant k (k may be traced)."""

    treedef: Any
    base_leaves: tuple
    varying: tuple[int, ...]  # indices of the leaves that differ
    stacked: tuple  # [K, ...] per varying leaf
    sizes: jax.Array  # [K, 3] object half-sizes

    @staticmethod
    def build(models: list[mjx.Model], sizes: np.ndarray) -> ModelVariants:
        base, treedef = jax.tree_util.tree_flatten(models[0])
        others = [jax.tree_util.tree_leaves(m) for m in models]
        varying = tuple(
            i for i, leaf in enumerate(base)
            if isinstance(leaf, jax.Array) and any(not np.array_equal(np.asarray(leaf), np.asarray(o[i])) for o in others)
        )  # fmt: skip
        stacked = tuple(jnp.stack([o[i] for o in others]) for i in varying)
        return ModelVariants(treedef, tuple(base), varying, stacked, jnp.asarray(sizes))

    @property
    def count(self) -> int:
        return int(self.sizes.shape[0])

    def model(self, k) -> mjx.Model:
        leaves = list(self.base_leaves)
        for i, s in zip(self.varying, self.stacked):
            leaves[i] = s[k]
        return jax.tree_util.tree_unflatten(self.treedef, leaves)
