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

from poir_mjx.envs.env import EnvParams, TaskEnv


@functools.lru_cache(maxsize=None)
def episode_mesh() -> Mesh:
    return Mesh(np.array(jax.devices()), ("episodes",))


def make_evaluator(env: TaskEnv, policy_fn, steps: int):
    """jit(vmap(episode)): (agent params, keys [B], EnvParams [B]) -> per-episode results.

    `env` is anything with reset(key, EnvParams), step(state, action) and obs_vector(state).
    """

    def episode(params, key, env_params: EnvParams):
        k_reset, k_run = jax.random.split(key)
        state = env.reset(k_reset, env_params)

        def body(state, k):
            action = policy_fn(params, env.obs_vector(state), k)
            return env.step(state, action), None

        state, _ = jax.lax.scan(body, state, jax.random.split(k_run, steps))
        return {
            "first_success": state.info["first_success"],
            "diverged": state.info["diverged"],
            "steps": state.info["step"],
        }

    return jax.jit(jax.vmap(episode, in_axes=(None, 0, 0)))


def episode_keys(seed: int, n: int) -> jax.Array:
    """One key per episode of a cell batch, the same in `sweep` and `eval` (so `eval` reproduces a sweep cell)."""
    return jax.random.split(jax.random.fold_in(jax.random.PRNGKey(seed), 1), n)


def replicate(tree):
    """Commit a pytree to every device of the episode mesh (replicated): the same sharding on every call,
    so a jitted function sees one signature whether its inputs are fresh or outputs of another jit."""
    return jax.device_put(tree, NamedSharding(episode_mesh(), PartitionSpec()))


def run_batch(evaluator, params, keys: jax.Array, env_params: EnvParams) -> dict[str, np.ndarray]:
    """`run_sharded`, results copied to the host as numpy arrays."""
    return jax.tree_util.tree_map(np.asarray, run_sharded(evaluator, params, keys, env_params))


def run_sharded(fn, params, keys: jax.Array, env_params: EnvParams):
    """Pad the batch to a multiple of the device count, shard it over the mesh, run `fn`, unpad (on device)."""
    n = keys.shape[0]
    devices = jax.device_count()
    pad = (-n) % devices
    if pad:
        keys = jnp.concatenate([keys, keys[:pad]])
        env_params = jax.tree_util.tree_map(lambda x: jnp.concatenate([x, x[:pad]]), env_params)
    sharding = NamedSharding(episode_mesh(), PartitionSpec("episodes"))
    keys = jax.device_put(keys, sharding)
    env_params = jax.device_put(env_params, sharding)
    out = fn(replicate(params), keys, env_params)
    return jax.tree_util.tree_map(lambda v: v[:n], out)
