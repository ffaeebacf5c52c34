"""Imitation rewards of whole trajectories from any source (imagined, or reached in a true simulator), with the
planner's own timing, under any of the three rewards: what the forensics and the oracle control score with."""

from __future__ import annotations

import dataclasses

import jax

from poir_mjx.core.agent import POIR, POIRParams


def variant(agent: POIR, reward: str) -> POIR:
    """The agent with `reward` as its planner's reward (everything else the same)."""
    planner = dataclasses.replace(agent.config.planner, reward=reward)
    return POIR(dataclasses.replace(agent.config, planner=planner), agent.obs_size, agent.act_size)


def step_rewards(agent: POIR, reward: str, params: POIRParams, states: jax.Array, actions: jax.Array) -> jax.Array:
    """Reward `reward` of each step of trajectories: states [H + 1, ..., ds] (normalised, the start state first),
    actions [H, ..., da] (normalised) -> [H, ...], with the planner's timing (next state, or MOREL's (s_t, a_t))."""
    v = variant(agent, reward)
    scored = states[1:] if v.scores_next_state() else states[:-1]
    return v.trajectory_rewards(params, scored, actions)
