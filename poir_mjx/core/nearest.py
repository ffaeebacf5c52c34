"""Exact nearest-expert-state search for the L2 reward: squared distances min_e ||s - e||^2.

Two exact searches, one answer:
- ``scan``: every expert state, chunk by chunk (memory O(Q * chunk) whatever E is). Candidates come from the
  expansion |s|^2 - 2 s.e + |e|^2 (one matmul at full float32 precision, Precision.HIGHEST; GPUs default to TF32),
  which cancels near the data (about 2e-3 of error at distance 0 in float32); the `refine` nearest candidates of each
  chunk are then measured directly as sum((s - e)^2), so the distance is exact to float32 rounding whenever the true
  nearest state is among them.
- ``shortlisted``: the planner's queries in one call are the imagined states of one start state, a few steps apart,
  so their nearest expert states lie near each other. The `size` expert states nearest to the queries' centre c are
  measured directly; by the triangle inequality every other expert state e is at least d(c, e) - d(s, c) >= b - d(s, c)
  from a query s, where b is the distance from c to the nearest state left out. A query whose shortlisted best is
  within that bound is certified exact; if any query of the call is not, the whole scan runs for the call (a loop of
  zero or one trip, so under vmap it costs the scan only while some episode of the batch needs it). On a 2-core CPU
  this is most of a POIR-L2 cell's time (``make bench-l2``, results/bench/l2-search.md).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

# Relative slack on the certificate's float32 distances (each carries a few ulps, ~1e-6): a query this close to its
# bound falls back to the scan rather than risk a wrong certificate.
_SLACK = 1e-5


def _chunks(expert: jax.Array, chunk: int) -> tuple[jax.Array, jax.Array]:
    """expert [E, d] zero-padded into [n, chunk, d], with the mask of real rows [n, chunk]."""
    e_count = expert.shape[0]
    n_chunks = -(-e_count // chunk)
    pad = n_chunks * chunk - e_count
    ex = jnp.concatenate([expert, jnp.zeros((pad, expert.shape[1]), jnp.float32)])
    valid = jnp.arange(n_chunks * chunk) < e_count
    return ex.reshape(n_chunks, chunk, -1), valid.reshape(n_chunks, chunk)


def _chunk_best(states: jax.Array, e: jax.Array, ok: jax.Array, refine: int) -> jax.Array:
    """min over one chunk's real rows of ||s - e||^2 (expansion for candidates, then measured directly): [Q]."""
    d2 = jnp.sum(states**2, -1)[:, None] - 2.0 * jnp.matmul(states, e.T, precision=jax.lax.Precision.HIGHEST)
    d2 = jnp.where(ok[None, :], d2 + jnp.sum(e**2, -1)[None, :], jnp.inf)
    if refine == 1:
        near = jnp.argmin(d2, -1)[:, None]  # [Q, 1]: a reduction, cheaper than top_k on a CPU
    else:
        _, near = jax.lax.top_k(-d2, refine)  # [Q, refine] candidate indices
    exact = jnp.sum((states[:, None, :] - e[near]) ** 2, -1)
    return jnp.where(ok[near], exact, jnp.inf).min(-1)


def scan(states: jax.Array, expert: jax.Array, chunk: int = 4096, refine: int = 8) -> jax.Array:
    """min_e ||s - e||^2 over every expert state: states [Q, d], expert [E, d] -> [Q] (see the module docstring)."""
    chunk = min(chunk, expert.shape[0])
    ex, valid = _chunks(expert, chunk)
    refine = min(refine, chunk)

    def body(best, xs):
        return jnp.minimum(best, _chunk_best(states, *xs, refine)), None

    best, _ = jax.lax.scan(body, jnp.full(states.shape[0], jnp.inf, jnp.float32), (ex, valid))
    return best


def shortlisted(states: jax.Array, expert: jax.Array, size: int, chunk: int = 4096, refine: int = 8,
                block: int = 256) -> jax.Array:  # fmt: skip
    """min_e ||s - e||^2, exact (module docstring): the `size` expert states nearest to the queries' centre, `block`
    at a time nearest first, until the triangle inequality certifies every query; the scan if the shortlist cannot."""
    return search(states, expert, size, chunk, refine, block)[0]


def search(states: jax.Array, expert: jax.Array, size: int, chunk: int = 4096, refine: int = 8,
           block: int = 256) -> tuple[jax.Array, jax.Array]:  # fmt: skip
    """``shortlisted``'s distances [Q] and how many expert states it measured: those of the shortlist it visited,
    plus E where it scanned them all (what make bench-l2 reports)."""
    e_count = expert.shape[0]
    block = max(1, min(block, size))
    size = -(-size // block) * block if size > 0 else 0
    if size <= 0 or size >= e_count:
        return scan(states, expert, chunk, refine), jnp.int32(e_count)
    q_count = states.shape[0]
    centre = jnp.mean(states, 0)
    neg, idx = jax.lax.top_k(-jnp.sqrt(jnp.sum((expert - centre) ** 2, -1)), size + 1)
    near, radius = expert[idx], -neg  # nearest first; radius[i]: the i-th nearest's distance from the centre
    slack = jnp.sqrt(jnp.sum((states - centre) ** 2, -1)) * (1 + _SLACK)

    def uncertified(best, i):  # every expert state from the i-th nearest on is at least radius[i] - d(s, centre) away
        bound = jnp.maximum(radius[i] * (1 - _SLACK) - slack, 0.0)
        return ~(best <= bound * bound * (1 - _SLACK))  # a NaN anywhere (a diverged query moves the centre): scan

    def shortlist_open(c):
        i, best = c
        return (i < size) & jnp.any(uncertified(best, i))

    def next_block(c):
        i, best = c
        e = jax.lax.dynamic_slice_in_dim(near, i, block, 0)
        return i + block, jnp.minimum(best, jnp.min(jnp.sum((states[:, None, :] - e[None]) ** 2, -1), -1))

    init = (jnp.int32(0), jnp.full(q_count, jnp.inf, jnp.float32))
    visited, best = jax.lax.while_loop(shortlist_open, next_block, init)
    # Not certified by the whole shortlist: every expert state, chunk by chunk (the loop index is the chunk, so the
    # compiler cannot hoist the scan out of a loop that runs no trip).
    chunk = min(chunk, e_count)
    ex, valid = _chunks(expert, chunk)
    trips = jnp.where(jnp.any(uncertified(best, size)), ex.shape[0], 0)
    refine = min(refine, chunk)

    def next_chunk(c):
        j, b = c
        return j + 1, jnp.minimum(b, _chunk_best(states, ex[j], valid[j], refine))

    _, best = jax.lax.while_loop(lambda c: c[0] < trips, next_chunk, (jnp.int32(0), best))
    return best, visited + jnp.where(trips > 0, e_count, 0)
