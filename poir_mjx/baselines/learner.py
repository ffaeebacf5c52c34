"""The contract every baseline implements, so one run loop trains, checkpoints, evaluates and plots them all.

A learner owns one compiled training phase: ``train(state, iterations)`` runs ``iterations`` x (a step of every
vectorised environment, or an unroll of several steps for on-policy methods, + that algorithm's updates) inside
``lax.scan``; the loop around it (``poir_mjx/baselines/run.py``)
evaluates the deterministic policy with the project's evaluator every so many environment steps, checkpoints the whole
``TrainState`` pytree by name, and resumes from it.

Environments follow ``poir_mjx.rollout.protocol.Env``; a learner vmaps ``reset``/``step`` over ``num_envs`` copies, one key
per environment and per step, and starts a fresh episode (same ``env_params``) when ``state.done`` or
``state.info["step"] >= episode_steps``. Training episodes are truncated, not terminated, at ``episode_steps``.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable, Protocol

import jax
import numpy as np


@dataclasses.dataclass(frozen=True)
class ExpertData:
    """Expert transitions in the environment's flat observation space (``env.obs_vector``), float32."""

    obs: np.ndarray  # [N, obs_size]
    actions: np.ndarray  # [N, act_size], in [-1, 1]
    next_obs: np.ndarray  # [N, obs_size]
    terminal: np.ndarray  # [N] bool: the transition ends its demonstration (absorbing-state wrappers need it)
    initial: np.ndarray  # [N] bool: the transition starts its demonstration (ValueDICE's initial-state term)


class Learner(Protocol):
    """One baseline on one environment; ``TrainState`` is any pytree (params, optimiser states, replay, env states, key,
    counters); it must hold a scalar int32 ``env_steps`` leaf reachable as ``env_steps(state)``."""

    name: str
    env_steps_per_iteration: int  # environment steps (all envs together) one ``train`` iteration takes

    def init(self, key: jax.Array, expert: ExpertData, env_params: Any) -> Any:
        """The initial TrainState: networks, optimisers, replay (seeded with expert data where the method does), and
        ``num_envs`` environments reset with ``env_params`` (scalar noise levels, broadcast inside)."""

    def train(self, state: Any, iterations: int) -> tuple[Any, dict[str, jax.Array]]:
        """``iterations`` x (environment step + updates) in one compiled call; metrics are per-iteration arrays
        (at least ``imitation_reward``: the method's own reward, mean over envs, and ``episode_success``: the fraction of
        episodes finished in this iteration that succeeded, NaN when none finished)."""

    def env_steps(self, state: Any) -> jax.Array:
        """Environment steps taken so far (all envs together)."""

    def policy_params(self, state: Any) -> Any:
        """What ``policy_fn`` needs (e.g. actor params and observation normaliser)."""

    def policy_fn(self) -> Callable[[Any, jax.Array, jax.Array], jax.Array]:
        """(policy params, obs_vector, key) -> action in [-1, 1]: the deterministic evaluation policy (mean action)."""
