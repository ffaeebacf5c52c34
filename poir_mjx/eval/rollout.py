"""One compiled evaluation per (task, method): lax.scan over control steps, vmap over episodes.

The per-episode perturbations (sigma_init, sigma_action) and keys are inputs, so a whole noise
grid is one batch. Episodes are sharded over every local device along the "episodes" axis of a
``jax.sharding.Mesh`` (one CPU device works unchanged).
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from poir_mjx.envs.env import EnvParams, TaskEnv, flatten_obs


@functools.lru_cache(maxsize=None)
def episode_mesh() -> Mesh:
    return Mesh(np.array(jax.devices()), ("episodes",))


def make_evaluator(env: TaskEnv, policy_fn, steps: int):
    """jit(vmap(episode)): (agent params, keys [B], EnvParams [B]) -> per-episode results."""

    def episode(params, key, env_params: EnvParams):
        k_reset, k_run = jax.random.split(key)
        state = env.reset(k_reset, env_params)

        def body(state, k):
            action = policy_fn(params, flatten_obs(state.obs), k)
            return env.step(state, action), None

        state, _ = jax.lax.scan(body, state, jax.random.split(k_run, steps))
        return {
            "first_success": state.info["first_success"],
            "diverged": state.info["diverged"],
            "steps": state.info["step"],
        }

    return jax.jit(jax.vmap(episode, in_axes=(None, 0, 0)))


def run_batch(evaluator, params, keys: jax.Array, env_params: EnvParams) -> dict[str, np.ndarray]:
    """Pad the batch to a multiple of the device count, shard it over the mesh, run, unpad."""
    n = keys.shape[0]
    devices = jax.device_count()
    pad = (-n) % devices
    if pad:
        keys = jnp.concatenate([keys, keys[:pad]])
        env_params = jax.tree_util.tree_map(lambda x: jnp.concatenate([x, x[:pad]]), env_params)
    sharding = NamedSharding(episode_mesh(), PartitionSpec("episodes"))
    keys = jax.device_put(keys, sharding)
    env_params = jax.device_put(env_params, sharding)
    out = evaluator(params, keys, env_params)
    return {k: np.asarray(v)[:n] for k, v in out.items()}
