"""MuJoCo Warp behind MJX's API (``PhysicsConfig.impl == "warp"``; mujoco-mjx 3.17 with warp-lang 1.18.0).

Three things differ from MJX's JAX pipeline, and the environment handles each here:
- Warp gives ``forward`` and ``step`` only, so a substep runs in robosuite's own order (forward, the controller,
  step) instead of the split pipeline;
- its mass matrix is MuJoCo's sparse lower triangle (``M_rownnz`` / ``M_colind``), made dense for the controller;
- its contact buffers belong to the batch, not to an episode: ``naconmax`` counts the contacts of every world of a
  vmapped call, and those fields carry no batch dimension (``mujoco/mjx/warp/types.py``, ``DATA_NON_VMAP``). So a
  Data is allocated for a known number of worlds (``TaskEnv.worlds``, set by ``sized_for`` where a batch is traced),
  outside any trace, and finished episodes are merged with ``Data.where``, which leaves those buffers alone.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import mjx

from poir_mjx.cached import builder


@builder
def jax_sizes(mj_model: mujoco.MjModel) -> tuple[int, int]:
    """(constraint rows, contacts) of one world as MJX's JAX pipeline allocates them: every candidate pair's."""
    d = jax.eval_shape(lambda: mjx.make_data(mj_model))
    return int(d._impl.efc_J.shape[0]), int(d._impl.ncon)


def make_data(mj_model: mujoco.MjModel, worlds: int, contacts: int = 0) -> mjx.Data:
    """A Data for a batch of `worlds` episodes: `contacts` per world (0: every candidate pair's) in the shared
    buffers, constraint rows per world as MJX's JAX pipeline sizes them. A new pytree around one cached allocation
    (MJX's Warp calls write into the Data they are given, so a shared object would keep a trace's values)."""
    return jax.tree_util.tree_map(lambda x: x, _allocated(mj_model, worlds, contacts))


@builder
def _allocated(mj_model: mujoco.MjModel, worlds: int, contacts: int) -> mjx.Data:
    """Made eagerly even when first asked for inside a trace (reset's), so the cache holds arrays, not tracers."""
    njmax, ncon = jax_sizes(mj_model)
    per_world = contacts or ncon
    with jax.ensure_compile_time_eval():
        return mjx.make_data(mj_model, impl="warp", njmax=max(njmax, 1), naconmax=max(per_world * worlds, 1))


def keep_where(keep_old: jax.Array, old: mjx.Data, new: mjx.Data) -> mjx.Data:
    """`old` where `keep_old`, else `new`, field by field; with Warp the batch's shared contact buffers stay `new`'s
    (``Data.where``; mjx 3.3's Data has no ``where``, and its JAX Data has no shared fields)."""
    if getattr(new, "impl", None) is not None and new.impl == mjx.Impl.WARP:
        return new.where(keep_old, old)
    return jax.tree_util.tree_map(lambda o, n: jnp.where(keep_old, o, n), old, new)


def full_m(mj_model: mujoco.MjModel, m: mjx.Model, d: mjx.Data) -> jnp.ndarray:
    """The dense [nv, nv] mass matrix (MuJoCo Warp gives a sparse model's as its lower triangle's entries)."""
    m_out = mjx.full_m(m, d)
    if m_out.ndim == 2:
        return m_out
    rows = np.repeat(np.arange(mj_model.nv), mj_model.M_rownnz)
    lower = jnp.zeros((mj_model.nv, mj_model.nv), d.qpos.dtype).at[rows, mj_model.M_colind].set(m_out)
    return lower + jnp.tril(lower, -1).T
