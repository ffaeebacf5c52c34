"""One episode, written once: reset, then ``lax.scan`` over control steps.

The evaluator, the online collector, the MJX expert and the video recorder all run their episodes
through ``run_episode`` (vmapped and jitted by the caller). Keys: the episode key splits into a reset
key and a run key; the run key seeds the policy's carry and splits into one key per step.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable

import jax

from poir_mjx.rollout.protocol import Env, for_batch

# act(params, carry, state, key) -> (action, carry)
ActFn = Callable[[Any, Any, Any, jax.Array], tuple[jax.Array, Any]]
# record(state, action, next_state) -> a pytree stacked over steps
RecordFn = Callable[[Any, jax.Array, Any], Any]


@dataclasses.dataclass(frozen=True)
class Policy:
    """How a rollout chooses actions: ``init(params, key) -> carry`` and ``act`` (see ActFn)."""

    act: ActFn
    init: Callable[[Any, jax.Array], Any] = lambda params, key: None


def stateless(env: Env, policy_fn: Callable) -> Policy:
    """A policy of the observation vector only: ``policy_fn(params, obs_vector, key) -> action``."""
    return Policy(act=lambda params, carry, state, key: (policy_fn(params, env.obs_vector(state), key), carry))


def run_episode(env: Env, policy: Policy, params, key: jax.Array, env_params, steps: int,
                record: RecordFn | None = None):  # fmt: skip
    """-> (final state, per-step records stacked over `steps`, or None)."""
    k_reset, k_run = jax.random.split(key)
    state = env.reset(k_reset, env_params)

    def body(carry, k):
        state, pc = carry
        action, pc = policy.act(params, pc, state, k)
        nxt = env.step(state, action)
        return (nxt, pc), (None if record is None else record(state, action, nxt))

    (state, _), records = jax.lax.scan(body, (state, policy.init(params, k_run)), jax.random.split(k_run, steps))
    return state, records


def outcome(state) -> dict[str, jax.Array]:
    """What an episode's final state says about it (``protocol.INFO_KEYS``)."""
    return {"first_success": state.info["first_success"], "diverged": state.info["diverged"],
            "steps": state.info["step"]}  # fmt: skip


def batched_episodes(env: Env, policy: Policy, steps: int, record: RecordFn | None = None):
    """jit(vmap(episode)): (params, keys [B], env params [B]) -> (outcome dict [B], records [B, T, ...]).
    The environment is sized for the batch it is traced with (``protocol.for_batch``)."""

    def batch(params, keys, env_params):
        sized = for_batch(env, keys.shape[0])

        def episode(params, key, env_params):
            state, records = run_episode(sized, policy, params, key, env_params, steps, record)
            return outcome(state), records

        return jax.vmap(episode, in_axes=(None, 0, 0))(params, keys, env_params)

    return jax.jit(batch)
