"""The paper's three imitation rewards (higher = closer to the expert's support).

All distances are Euclidean, in the (normalised) spaces the agent works in, computed in float32.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from poir_mjx.core import nearest


def l2_reward(states: jax.Array, expert: jax.Array, chunk: int = 4096, refine: int = 8, shortlist: int = 0,
              groups: int = 1) -> jax.Array:  # fmt: skip
    """-min_e ||s - e||_2 for every query state (exact): states [Q, d], expert [E, d] -> [Q].

    `shortlist` > 0 measures, for each of `groups` consecutive groups of queries, that many expert states nearest to
    the group's centre first, and scans every expert state only for the queries the triangle inequality cannot
    certify (the same distances, far fewer measured: one head's imagined states lie close together); 0 scans them
    all, `chunk` at a time (core/nearest.py).
    """
    states, expert = jnp.asarray(states, jnp.float32), jnp.asarray(expert, jnp.float32)
    return -jnp.sqrt(nearest.shortlisted(states, expert, shortlist, chunk, refine, groups))


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


def excess(reward: jax.Array, level: jax.Array) -> jax.Array:
    """A disagreement reward (-d) relative to the expert data's own level: -max(d - level, 0)."""
    return jnp.minimum(reward + level, 0.0)


def disagreement_level(disagreement_fn, params, inputs: jax.Array, quantile: float, chunk: int = 2048) -> jax.Array:
    """The `quantile` quantile of disagreement_fn(params, x) (a compiled DRIL or MOREL disagreement, [n] for
    x [n, d]) over the rows of `inputs`, chunk by chunk (one chunk shape, so K x n x d never sits in memory)."""
    inputs = jnp.asarray(inputs, jnp.float32)
    n = inputs.shape[0]
    chunk = min(chunk, n)
    fn = disagreement_fn
    parts = []
    for start in range(0, n, chunk):
        x = inputs[start : start + chunk]
        rows = x.shape[0]
        if rows < chunk:
            x = jnp.concatenate([x, jnp.broadcast_to(x[:1], (chunk - rows, x.shape[1]))])
        parts.append(fn(params, x)[:rows])
    return jnp.quantile(jnp.concatenate(parts), quantile).astype(jnp.float32)
