"""The paper's three imitation rewards (higher = closer to the expert's support).

All distances are Euclidean, in the (normalised) spaces the agent works in, computed in float32.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


def l2_reward(states: jax.Array, expert: jax.Array, chunk: int = 4096, refine: int = 8) -> jax.Array:
    """-min_e ||s - e||_2 for every query state (exact), scanning the expert states in chunks.

    states [Q, d], expert [E, d] -> [Q]. Memory is O(Q * chunk) whatever E is. Candidates come from
    the expansion |s|^2 - 2 s.e + |e|^2 (one matmul at full float32 precision, Precision.HIGHEST; GPUs
    default to TF32), which cancels near the data (about 2e-3 of error at distance 0 in float32); the
    `refine` nearest candidates of each chunk are then measured directly as sum((s - e)^2), so the
    distance is exact to float32 rounding whenever the true nearest state is among them.
    """
    states, expert = jnp.asarray(states, jnp.float32), jnp.asarray(expert, jnp.float32)
    e_count = expert.shape[0]
    chunk = min(chunk, e_count)
    refine = min(refine, chunk)
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
        if refine == 1:
            near = jnp.argmin(d2, -1)[:, None]  # [Q, 1]: a reduction, cheaper than top_k on a CPU
        else:
            _, near = jax.lax.top_k(-d2, refine)  # [Q, refine] candidate indices
        exact = jnp.sum((states[:, None, :] - e[near]) ** 2, -1)
        exact = jnp.where(ok[near], exact, jnp.inf)
        return jnp.minimum(best, exact.min(-1)), None

    best, _ = jax.lax.scan(body, jnp.full(states.shape[0], jnp.inf, jnp.float32), (ex, valid))
    return -jnp.sqrt(best)


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
