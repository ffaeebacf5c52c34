"""The paper's three imitation rewards (higher = closer to the expert's support).

All distances are Euclidean, in the (normalised) spaces the agent works in, computed in float32.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


def l2_reward(states: jax.Array, expert: jax.Array, chunk: int = 4096) -> jax.Array:
    """-min_e ||s - e||_2 for every query state (exact), scanning the expert states in chunks.

    states [Q, d], expert [E, d] -> [Q]. Memory is O(Q * chunk) whatever E is. The matmul runs at
    full float32 precision (Precision.HIGHEST; GPUs default to TF32).
    """
    states, expert = jnp.asarray(states, jnp.float32), jnp.asarray(expert, jnp.float32)
    e_count = expert.shape[0]
    chunk = min(chunk, e_count)
    n_chunks = -(-e_count // chunk)
    pad = n_chunks * chunk - e_count
    ex = jnp.concatenate([expert, jnp.zeros((pad, expert.shape[1]), jnp.float32)])
    valid = jnp.arange(n_chunks * chunk) < e_count
    ex = ex.reshape(n_chunks, chunk, -1)
    valid = valid.reshape(n_chunks, chunk)
    s2 = jnp.sum(states**2, -1)

    def body(best, xs):
        e, ok = xs
        d2 = s2[:, None] - 2.0 * jnp.matmul(states, e.T, precision=jax.lax.Precision.HIGHEST) + jnp.sum(e**2, -1)[None, :]
        d2 = jnp.where(ok[None, :], d2, jnp.inf)
        return jnp.minimum(best, d2.min(-1)), None

    best, _ = jax.lax.scan(body, jnp.full(states.shape[0], jnp.inf, jnp.float32), (ex, valid))
    return -jnp.sqrt(jnp.maximum(best, 0.0))


def approximate_subset(expert: jax.Array, size: int, key: jax.Array) -> jax.Array:
    """The approximate L2 option: a fixed random subset of the expert states (distance is an upper bound)."""
    if size <= 0 or size >= expert.shape[0]:
        return expert
    return expert[jax.random.choice(key, expert.shape[0], (size,), replace=False)]


def max_pairwise_distance(x: jax.Array) -> jax.Array:
    """x [K, ..., d] -> max over member pairs (i, j) of ||x_i - x_j||_2, shape [...]."""
    diff = x[:, None] - x[None, :]
    return jnp.sqrt(jnp.max(jnp.sum(diff**2, -1), axis=(0, 1)))


def dril_reward(bc_actions: jax.Array) -> jax.Array:
    """-max_{i,j} ||pi_i(s) - pi_j(s)||: BC-ensemble disagreement. bc_actions [K, ..., da]."""
    return -max_pairwise_distance(bc_actions)


def morel_reward(wm_predictions: jax.Array) -> jax.Array:
    """-max_{i,j} ||P_i(s, a) - P_j(s, a)||: world-model disagreement. wm_predictions [K, ..., ds]."""
    return -max_pairwise_distance(wm_predictions)
