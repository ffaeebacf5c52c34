"""The environment contract every rollout relies on, written down once.

``poir_mjx.envs.env.TaskEnv`` (MJX tasks) and the tests' point-mass toy implement it. A ``State`` is a
pytree (``poir_mjx.envs.env.State``) whose ``info`` dict carries at least ``INFO_KEYS``.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import jax

# Per-episode bookkeeping the rollouts read from ``state.info``:
#   step           int32, control steps taken
#   first_success  int32, the 1-based step of the first success, -1 if none yet
#   diverged       bool, the physics produced a non-finite state (the episode is frozen from then on)
INFO_KEYS = ("step", "first_success", "diverged")


@runtime_checkable
class Env(Protocol):
    """reset(rng, params) -> State; step(state, action) -> State; obs_vector(state) -> [obs_size]."""

    def reset(self, rng: jax.Array, params: Any) -> Any: ...

    def step(self, state: Any, action: jax.Array) -> Any: ...

    def obs_vector(self, state: Any) -> jax.Array: ...


def for_batch(env: Any, episodes: int) -> Any:
    """`env` for a traced batch of `episodes` (call it inside the jitted function, from an input's shape, before
    vmapping ``reset``): an environment whose buffers are shared by a batch (MuJoCo Warp's contacts) sizes them
    by it through its ``sized_for``; any other environment is returned as it is."""
    sized = getattr(env, "sized_for", None)
    return env if sized is None else sized(episodes)
