"""The states a video shows, recorded by the one episode rollout (``rollout.episode``) in MJX."""

from __future__ import annotations

import dataclasses

import numpy as np

from poir_mjx.rollout.episode import batched_episodes, stateless
from poir_mjx.rollout.sharding import run_batch


@dataclasses.dataclass(frozen=True)
class Recording:
    """Episodes as recorded: frame t is the state after t actions (t = 0: the starting state)."""

    qpos: np.ndarray  # [B, T, nq] joint positions, laid out as in the task's model
    success: np.ndarray  # [B, T] the task's success test on each frame's state
    variant: np.ndarray  # [B] the episode's object-size variant (Lift: which cube size; 0 otherwise)
    first_success: np.ndarray  # [B] 1-based step of the first success, -1 if none
    diverged: np.ndarray  # [B] the physics produced a non-finite state (frozen from then on)


def record_state(state, action, next_state) -> dict:
    """What a frame needs of a state (the rollout's record hook; the state before `action`)."""
    return {"qpos": state.data.qpos, "success": state.success, "variant": state.info["variant"]}


def recorder(env, policy_fn, steps: int):
    """jit(vmap(episode)) recording every state: (params, keys [B], EnvParams [B]) -> (outcome, records).
    `policy_fn(params, obs_vector, key) -> action`; keep the result to reuse its compilation."""
    return batched_episodes(env, stateless(env, policy_fn), steps, record_state)


def record_episodes(run, params, keys, env_params) -> Recording:
    """One MJX episode per key with `run = recorder(...)`, its states copied to the host."""
    out, rec = run_batch(run, params, keys, env_params)
    return Recording(qpos=rec["qpos"], success=rec["success"].astype(bool), variant=rec["variant"][:, 0],
                     first_success=out["first_success"], diverged=out["diverged"].astype(bool))  # fmt: skip
