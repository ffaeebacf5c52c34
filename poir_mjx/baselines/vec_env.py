"""``num_envs`` copies of one environment stepped together (vmap), each starting a fresh episode when its own ends.

An episode ends when the environment says ``done`` (its horizon, or diverged physics) or after ``episode_steps``
control steps. The project's environments have no true terminations: ``TaskEnv.done`` is its horizon or a divergence
and the point-mass toy's is its horizon, so every end is a truncation (learners bootstrap through it; DAC's absorbing
state applies to the expert's demonstration ends only). A transition out of diverged physics is marked invalid.

Keys: ``step`` takes one key and splits it into one reset key per environment; an environment draws its own noise
from its state (``info["rng"]``), which a reset reseeds. The ``Transition`` returned holds the observation before the
step and the one it led to (before any reset), so replay never mixes two episodes in one transition.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from poir_mjx.rollout.protocol import Env


@struct.dataclass
class VecState:
    env: Any  # the environments' states, leaves [E, ...]
    params: Any  # env params broadcast to [E]
    obs: jax.Array  # [E, obs_size]: each environment's current observation vector


@struct.dataclass
class Transition:
    obs: jax.Array  # [E, do]
    act: jax.Array  # [E, da]
    next_obs: jax.Array  # [E, do]
    end: jax.Array  # [E] bool: the episode ended with this step (a fresh one starts next)
    valid: jax.Array  # [E] bool: False for a step out of diverged physics or with a non-finite observation
    success: jax.Array  # [E] bool: the episode that ended here succeeded at some step (first_success >= 0)


def _select(mask: jax.Array, a, b):
    """Per environment: a where mask [E], else b (pytrees with leaves [E, ...])."""
    return jax.tree_util.tree_map(lambda x, y: jnp.where(mask.reshape((-1,) + (1,) * (x.ndim - 1)), x, y), a, b)


@dataclasses.dataclass(frozen=True)
class VecEnv:
    env: Env
    num_envs: int
    episode_steps: int

    def __post_init__(self):
        if self.num_envs < 1:
            raise ValueError(f"num_envs: must be positive, got {self.num_envs}")
        if self.episode_steps < 1:
            raise ValueError(f"episode_steps: must be positive, got {self.episode_steps}")

    def reset(self, key: jax.Array, env_params: Any) -> VecState:
        """Reset every environment (own key each) with ``env_params`` (scalar leaves, broadcast to [E])."""
        params = jax.tree_util.tree_map(lambda x: jnp.broadcast_to(jnp.asarray(x), (self.num_envs,) + jnp.shape(x)),
                                        env_params)  # fmt: skip
        states = jax.vmap(self.env.reset)(jax.random.split(key, self.num_envs), params)
        return VecState(env=states, params=params, obs=self._obs(states))

    def _obs(self, states) -> jax.Array:
        return jax.vmap(self.env.obs_vector)(states).astype(jnp.float32)

    def step(self, vs: VecState, actions: jax.Array, key: jax.Array) -> tuple[VecState, Transition]:
        """Step every environment with its action [E, da]; environments whose episode ended are reset."""
        nxt = jax.vmap(self.env.step)(vs.env, actions)
        next_obs = self._obs(nxt)
        diverged = nxt.info["diverged"] if "diverged" in nxt.info else jnp.zeros(self.num_envs, bool)
        valid = ~diverged & jnp.all(jnp.isfinite(next_obs), axis=-1)
        end = nxt.done | (nxt.info["step"] >= self.episode_steps) | ~valid
        success = end & (nxt.info["first_success"] >= 0)
        # resets (an MJX forward pass each) run only on the steps where some episode ended
        def reset_ended():
            return _select(end, jax.vmap(self.env.reset)(jax.random.split(key, self.num_envs), vs.params), nxt)

        states = jax.lax.cond(end.any(), reset_ended, lambda: nxt)
        tr = Transition(obs=vs.obs, act=actions.astype(jnp.float32), next_obs=jnp.where(valid[:, None], next_obs, 0.0),
                        end=end, valid=valid, success=success)  # fmt: skip
        return VecState(env=states, params=vs.params, obs=self._obs(states)), tr


def episode_success(tr: Transition) -> jax.Array:
    """The fraction of the episodes that ended in this step and succeeded; NaN when none ended."""
    ended = tr.end.sum()
    return jnp.where(ended > 0, tr.success.sum() / jnp.maximum(ended, 1), jnp.nan)
