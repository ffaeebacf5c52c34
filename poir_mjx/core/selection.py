"""How the planner turns its imagined trajectories into one action: scoring the returns, choosing the top_k.

The trajectories sit in the [K, M] head layout (trajectory n = k + K j keeps head k; cells with n >= N are padding,
their return -inf). Options (``PlannerConfig``):
- scoring "head_centred": each return minus its head's mean return, so a head's own model error (which moves all
  of that head's returns together) no longer decides the ranking;
- selection "top_k" (the paper), "random" (the control: the returns ignored), "head_balanced" (the best
  top_k / K of every head, so the action averages all heads as EBC does, and only the noise within a head is ranked).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

RANDOM_STREAM = 0x5E1EC7  # the random selection's own key stream (fold_in), apart from the rollouts'


def real_mask(k: int, m: int, n: int) -> jax.Array:
    """[K, M]: True where trajectory k + K j is one of the N real ones."""
    return jnp.arange(k)[:, None] + k * jnp.arange(m)[None, :] < n


def head_centred(ret: jax.Array, real: jax.Array) -> jax.Array:
    """Returns [K, M] minus each head's mean over its real trajectories (padding stays -inf)."""
    mean = jnp.sum(jnp.where(real, ret, 0.0), 1, keepdims=True) / jnp.maximum(real.sum(1, keepdims=True), 1)
    return jnp.where(real, ret - mean, -jnp.inf)


def real_trajectories(ret: jax.Array, first: jax.Array, n: int) -> tuple[jax.Array, jax.Array]:
    """The N real trajectories of a [K, M] layout in the order n = 0..N-1: (returns [N], first actions [N, da])."""
    return ret.T.reshape(-1)[:n], first.transpose(1, 0, 2).reshape(-1, first.shape[-1])[:n]


def top_k_mean(returns: jax.Array, actions: jax.Array, k: int) -> jax.Array:
    """Mean of the actions of the k largest returns (k = 1: argmax). returns [N], actions [N, d].

    NaN returns rank last (as -inf): ``lax.top_k`` would rank them first.
    """
    _, top = jax.lax.top_k(jnp.where(jnp.isnan(returns), -jnp.inf, returns), k)
    return actions[top].mean(0)


def head_balanced_mean(ret: jax.Array, first: jax.Array, top_k: int) -> jax.Array:
    """The mean first action of the best max(1, top_k // K) trajectories of every head, [K, M] layout (padding is
    -inf, so a head ranks its real trajectories first; every head has at least one when N >= K)."""
    k, m = ret.shape
    per_head = min(max(1, top_k // k), m)
    _, top = jax.lax.top_k(jnp.where(jnp.isnan(ret), -jnp.inf, ret), per_head)  # [K, per_head]
    return jnp.take_along_axis(first, top[..., None], 1).mean((0, 1))


def select(selection: str, ret: jax.Array, first: jax.Array, key: jax.Array, n: int, top_k: int) -> jax.Array:
    """The mean first action (normalised) of the chosen trajectories of a [K, M] layout."""
    if selection == "head_balanced":
        return head_balanced_mean(ret, first, top_k)
    ret, first = real_trajectories(ret, first, n)
    if selection == "random":
        pick = jax.random.choice(jax.random.fold_in(key, RANDOM_STREAM), n, (top_k,), replace=False)
        return first[pick].mean(0)
    return top_k_mean(ret, first, top_k)
