"""One compiled evaluation per (task, method): ``rollout.episode`` vmapped over episodes, sharded over devices.

The per-episode perturbations (sigma_init, sigma_action) and keys are inputs, so a whole noise
grid is one batch.
"""

from __future__ import annotations

import jax
import numpy as np

from poir_mjx.rollout.episode import Policy, batched_episodes, stateless
from poir_mjx.rollout.protocol import Env


def make_evaluator(env: Env, policy, steps: int):
    """jit(vmap(episode)): (agent params, keys [B], EnvParams [B]) -> per-episode outcomes
    (first_success, diverged, steps). `policy`: a ``Policy`` (it may read the simulator's state) or a function
    ``policy_fn(params, obs_vector, key) -> action``."""
    episodes = batched_episodes(env, policy if isinstance(policy, Policy) else stateless(env, policy), steps)
    return jax.jit(lambda params, keys, env_params: episodes(params, keys, env_params)[0])


def episode_keys(seed: int, n: int) -> jax.Array:
    """One key per episode of a cell batch, the same in `sweep` and `eval` (so `eval` reproduces a sweep cell)."""
    return jax.random.split(jax.random.fold_in(jax.random.PRNGKey(seed), 1), n)


def success_record(outcomes, seconds: float) -> dict:
    """A learning curve's evaluation entry from per-episode outcomes (``first_success`` >= 0 is a success):
    successes, episodes, success_rate, diverged and the evaluation's wall time."""
    first, diverged = np.asarray(outcomes["first_success"]), np.asarray(outcomes["diverged"])
    k, n = int((first >= 0).sum()), int(first.shape[0])
    return {"successes": k, "episodes": n, "success_rate": k / n, "diverged": int(diverged.sum()), "wall_s": seconds}
