"""Episodes sharded over every local device along the "episodes" axis of a ``jax.sharding.Mesh``.

One CPU device works unchanged; on several GPUs the same call spreads the batch over them.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from poir_mjx.cached import builder


@builder
def episode_mesh() -> Mesh:
    return Mesh(np.array(jax.devices()), ("episodes",))


def replicate(tree):
    """Commit a pytree to every device of the episode mesh (replicated): the same sharding on every call,
    so a jitted function sees one signature whether its inputs are fresh or outputs of another jit."""
    return jax.device_put(tree, NamedSharding(episode_mesh(), PartitionSpec()))


def shard_inputs(params, keys: jax.Array, env_params):
    """(params replicated, keys and env params padded to a multiple of the device count and sharded over the mesh)."""
    n = keys.shape[0]
    pad = (-n) % jax.device_count()
    if pad:
        keys = jnp.concatenate([keys, keys[:pad]])
        env_params = jax.tree_util.tree_map(lambda x: jnp.concatenate([x, x[:pad]]), env_params)
    sharding = NamedSharding(episode_mesh(), PartitionSpec("episodes"))
    return replicate(params), jax.device_put(keys, sharding), jax.device_put(env_params, sharding)


def run_sharded(fn, params, keys: jax.Array, env_params):
    """Pad the batch to a multiple of the device count, shard it over the mesh, run `fn`, unpad (on device)."""
    out = fn(*shard_inputs(params, keys, env_params))
    return jax.tree_util.tree_map(lambda v: v[: keys.shape[0]], out)


def run_batch(fn, params, keys: jax.Array, env_params) -> dict[str, np.ndarray]:
    """`run_sharded`, results copied to the host as numpy arrays."""
    return jax.tree_util.tree_map(np.asarray, run_sharded(fn, params, keys, env_params))
