"""A 2-D point mass with the env protocol (reset / step / obs_vector) and a known model mismatch.

The expert data (tests/core/toy.py) come from s' = s + a. The deployment environment adds a
constant drift `drift_y` to y on every step (a slope the demonstrations never showed) and scales
the y action by `gain_y`; it starts with y ~ N(0, sigma_init). Success: x >= 1 while |y| < 0.05.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from poir_mjx.envs.env import State


@dataclasses.dataclass(frozen=True)
class PointMassEnv:
    drift_y: float = 0.02
    gain_y: float = 1.0
    horizon: int = 30

    def obs_vector(self, state: State) -> jax.Array:
        return state.obs["s"]

    def reset(self, rng, params) -> State:
        k_init, k_ep = jax.random.split(rng)
        s = jnp.array([0.0, 1.0]) * params.sigma_init * jax.random.normal(k_init, (2,))
        info = {"rng": k_ep, "step": jnp.zeros((), jnp.int32), "first_success": jnp.full((), -1, jnp.int32),
                "diverged": jnp.zeros((), bool), "sigma_action": jnp.asarray(params.sigma_action, s.dtype)}  # fmt: skip
        return State(data=s, obs={"s": s}, done=jnp.zeros((), bool), success=jnp.zeros((), bool), info=info)

    def step(self, state: State, action) -> State:
        rng, k = jax.random.split(state.info["rng"])
        a = jnp.clip(action, -1, 1).astype(state.data.dtype) + state.info["sigma_action"] * jax.random.normal(k, (2,))
        s = state.data + jnp.array([1.0, self.gain_y]) * a + jnp.array([0.0, self.drift_y])
        step = state.info["step"] + 1
        success = (s[0] >= 1.0) & (jnp.abs(s[1]) < 0.05)
        first = jnp.where((state.info["first_success"] < 0) & success, step, state.info["first_success"])
        new = State(data=s, obs={"s": s}, done=step >= self.horizon, success=success,
                    info=dict(state.info, rng=rng, step=step, first_success=first))  # fmt: skip
        return jax.tree_util.tree_map(lambda old, nw: jnp.where(state.done, old, nw), state, new)
