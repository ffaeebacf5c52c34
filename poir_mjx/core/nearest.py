"""Exact nearest-expert-state search for the L2 reward: squared distances min_e ||s - e||^2.

Two exact searches, one answer:
- ``scan``: every expert state, chunk by chunk (memory O(Q * chunk) whatever E is). Candidates come from the
  expansion |s|^2 - 2 s.e + |e|^2 (one matmul at full float32 precision, Precision.HIGHEST; GPUs default to TF32),
  which cancels near the data (about 2e-3 of error at distance 0 in float32); the `refine` nearest candidates of each
  chunk are then measured directly as sum((s - e)^2), so the distance is exact to float32 rounding whenever the true
  nearest state is among them.
- ``shortlisted``: the planner's queries in one call are the imagined states of one start state, a few steps apart,
  and those of one head (one world model) lie together. Per group of queries, the `size` expert states nearest to the
  group's centre c are measured, nearest first; by the triangle inequality every other expert state e is at least
  d(c, e) - d(s, c) >= b - d(s, c) from a query s, where b is the distance from c to the nearest state not yet
  measured, so a query whose best is within that bound is certified exact. The queries no shortlist certifies are
  scanned against every expert state, a few at a time (under vmap, as many trips as the batch's worst call needs).
  ``make bench-l2`` (results/bench/l2-search.md) times both in a real planner.
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
                groups: int = 1) -> jax.Array:  # fmt: skip
    """min_e ||s - e||^2, exact (module docstring): states [Q, d] in `groups` consecutive groups of queries that lie
    together (the planner's: one per head), each searched in its own shortlist; the queries a shortlist cannot certify
    are scanned against every expert state."""
    return search(states, expert, size, chunk, refine, groups)[0]


def _group_shortlist(states: jax.Array, expert: jax.Array, size: int, block: int) -> tuple[jax.Array, ...]:
    """One group's queries [q, d] against the `size` expert states nearest to their centre, `block` at a time until
    every query is certified: (best squared distances [q], certified [q], expert states measured)."""
    centre = jnp.mean(states, 0)
    neg, idx = jax.lax.top_k(-jnp.sqrt(jnp.sum((expert - centre) ** 2, -1)), size + 1)
    near, radius = expert[idx], -neg  # nearest first; radius[i]: the i-th nearest's distance from the centre
    slack = jnp.sqrt(jnp.sum((states - centre) ** 2, -1)) * (1 + _SLACK)

    def certified(best, i):  # every expert state from the i-th nearest on is at least radius[i] - d(s, centre) away
        bound = jnp.maximum(radius[i] * (1 - _SLACK) - slack, 0.0)
        return best <= bound * bound * (1 - _SLACK)  # False for NaN (a diverged query moves the centre): scanned

    def shortlist_open(c):
        i, best = c
        return (i < size) & ~jnp.all(certified(best, i))

    def next_block(c):
        i, best = c
        e = jax.lax.dynamic_slice_in_dim(near, i, block, 0)
        return i + block, jnp.minimum(best, jnp.min(jnp.sum((states[:, None, :] - e[None]) ** 2, -1), -1))

    init = (jnp.int32(0), jnp.full(states.shape[0], jnp.inf, jnp.float32))
    visited, best = jax.lax.while_loop(shortlist_open, next_block, init)
    return best, certified(best, visited), visited


def search(states: jax.Array, expert: jax.Array, size: int, chunk: int = 4096, refine: int = 8, groups: int = 1,
           block: int = 256, spill: int = 32) -> tuple[jax.Array, dict]:  # fmt: skip
    """``shortlisted``'s distances [Q] and what it measured: {"shortlist": expert states measured per group (mean),
    "scanned": queries scanned against every expert state} (what make bench-l2 reports). The uncertified queries
    are scanned `spill` at a time (a loop of as many trips as they need: under vmap, as the batch's worst needs)."""
    q_count, e_count = states.shape[0], expert.shape[0]
    block = max(1, min(block, size))
    size = -(-size // block) * block if size > 0 else 0
    if size <= 0 or size >= e_count or q_count % groups:
        return scan(states, expert, chunk, refine), {"shortlist": jnp.float32(0), "scanned": jnp.int32(q_count)}
    grouped = states.reshape(groups, q_count // groups, -1)
    best, ok, visited = jax.vmap(lambda g: _group_shortlist(g, expert, size, block))(grouped)
    best, ok = best.reshape(-1), ok.reshape(-1)
    # The queries no shortlist certified, `spill` at a time, against every expert state. Indices past the last one
    # are q_count (dropped when written back); the loop index picks the queries, so nothing is hoisted out of it.
    spill = min(spill, q_count)
    todo = jnp.nonzero(~ok, size=q_count, fill_value=q_count)[0]
    n_todo = jnp.sum(~ok)
    padded = jnp.concatenate([states, jnp.zeros((1, states.shape[1]), states.dtype)])

    def next_spill(c):
        j, b = c
        ids = jax.lax.dynamic_slice_in_dim(jnp.concatenate([todo, jnp.full(spill, q_count)]), j * spill, spill)
        return j + 1, b.at[ids].min(scan(padded[ids], expert, chunk, refine), mode="drop")

    trips = -(-n_todo // spill)
    _, best = jax.lax.while_loop(lambda c: c[0] < trips, next_spill, (jnp.int32(0), best))
    return best, {"shortlist": jnp.mean(visited.astype(jnp.float32)), "scanned": n_todo}
