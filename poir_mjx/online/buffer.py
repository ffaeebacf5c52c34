"""A fixed-capacity ring buffer of transitions that lives on the device (a pytree, updated functionally).

Rows marked invalid (after an episode ended or its physics diverged) are stored with zeros and
weight 0, so a batch shape never depends on the data.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct


@struct.dataclass
class ReplayBuffer:
    obs: jax.Array  # [C, do]
    act: jax.Array  # [C, da]
    next_obs: jax.Array  # [C, do]
    valid: jax.Array  # [C] float32, 1 for a real transition
    size: jax.Array  # int32: filled rows (<= C)
    ptr: jax.Array  # int32: the next row written

    @property
    def capacity(self) -> int:
        return self.obs.shape[0]


def init(capacity: int, obs_size: int, act_size: int, dtype=jnp.float32) -> ReplayBuffer:
    if capacity <= 0:
        raise ValueError(f"buffer_capacity: must be positive, got {capacity}")
    return ReplayBuffer(
        obs=jnp.zeros((capacity, obs_size), dtype),
        act=jnp.zeros((capacity, act_size), dtype),
        next_obs=jnp.zeros((capacity, obs_size), dtype),
        valid=jnp.zeros((capacity,), jnp.float32),
        size=jnp.zeros((), jnp.int32),
        ptr=jnp.zeros((), jnp.int32),
    )


@jax.jit
def add(buf: ReplayBuffer, obs: jax.Array, act: jax.Array, next_obs: jax.Array, valid: jax.Array) -> ReplayBuffer:
    """Append n transitions (oldest rows overwritten once full); if n > capacity only the last ones stay."""
    c = buf.capacity
    n = obs.shape[0]
    if n > c:
        obs, act, next_obs, valid = obs[-c:], act[-c:], next_obs[-c:], valid[-c:]
        n = c
    ok = valid.astype(bool)
    rows = (buf.ptr + jnp.arange(n)) % c

    def put(store, x):
        x = jnp.where(ok.reshape((-1,) + (1,) * (x.ndim - 1)), x, 0).astype(store.dtype)
        return store.at[rows].set(x)

    return ReplayBuffer(
        obs=put(buf.obs, obs),
        act=put(buf.act, act),
        next_obs=put(buf.next_obs, next_obs),
        valid=buf.valid.at[rows].set(ok.astype(jnp.float32)),
        size=jnp.minimum(buf.size + n, c).astype(jnp.int32),
        ptr=((buf.ptr + n) % c).astype(jnp.int32),
    )
