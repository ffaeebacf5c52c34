"""Vectorised environments with auto-reset, for PPO (a private stand-in for the off-policy learners' ``vec_env``).

``num_envs`` copies of a ``poir_mjx.rollout.protocol.Env`` stepped with ``vmap``, one key per environment and per step.
An episode ends when ``state.done`` or ``state.info["step"] >= episode_steps`` (a truncation); the copy then starts a
fresh episode with the same ``env_params``. The step returns what the learner needs of the step it just took (the
observation the action led to, before any reset, so truncated episodes can be bootstrapped from it).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax
import jax.numpy as jnp

from poir_mjx.rollout.protocol import Env


class StepOut(NamedTuple):
    """What one vectorised step says about each environment, all [num_envs, ...]."""

    next_obs: jax.Array  # the observation the action led to (before any reset), as is (non-finite if diverged)
    ended: jax.Array  # bool: the episode ended at this step (done, diverged or episode_steps reached); reset follows
    diverged: jax.Array  # bool: the physics went non-finite (terminal: not bootstrapped)
    success: jax.Array  # bool: an ended episode had succeeded (``first_success >= 0``); False where not ended


def broadcast_params(env_params: Any, num_envs: int) -> Any:
    """Scalar noise levels -> one copy per environment (float32 leaves stay float32)."""
    return jax.tree_util.tree_map(lambda x: jnp.broadcast_to(jnp.asarray(x), (num_envs,) + jnp.shape(x)), env_params)


def reset(env: Env, key: jax.Array, env_params: Any) -> Any:
    """Batched reset: env_params [num_envs] (see ``broadcast_params``), one key per environment."""
    num_envs = jax.tree_util.tree_leaves(env_params)[0].shape[0]
    return jax.vmap(env.reset)(jax.random.split(key, num_envs), env_params)


def observe(env: Env, states: Any) -> jax.Array:
    """[num_envs, obs_size] observation vectors, non-finite entries replaced by 0 (a diverged episode's last state)."""
    obs = jax.vmap(env.obs_vector)(states)
    return jnp.where(jnp.isfinite(obs), obs, 0.0).astype(jnp.float32)


def step(env: Env, episode_steps: int, states: Any, env_params: Any, actions: jax.Array, key: jax.Array):
    """One step of every environment, then a reset of those whose episode ended -> (states, StepOut)."""
    nxt = jax.vmap(env.step)(states, actions)
    next_obs = jax.vmap(env.obs_vector)(nxt).astype(jnp.float32)
    diverged = nxt.info["diverged"] | ~jnp.all(jnp.isfinite(next_obs), -1)
    ended = nxt.done | diverged | (nxt.info["step"] >= episode_steps)

    def with_resets(nxt):
        fresh = reset(env, key, env_params)

        def pick(new, old):
            return jnp.where(ended.reshape(ended.shape + (1,) * (new.ndim - 1)), new, old)

        return jax.tree_util.tree_map(pick, fresh, nxt)

    # resets are computed only on steps where some episode ended (MJX resets run the physics' forward pass)
    states = jax.lax.cond(jnp.any(ended), with_resets, lambda s: s, nxt)
    return states, StepOut(next_obs, ended, diverged, ended & (nxt.info["first_success"] >= 0))
