"""The compiled parts of the forensics: one planner call taken apart, and rewards of states from any source.

Every candidate a call imagines is scored by all three imitation rewards (L2, DRIL, MOREL) whatever reward the
planner ranks with: the candidates (prior, noise, world model) do not depend on the reward, so one call shows how
each reward would have ranked the same trajectories, in the world model (``call``) and in the true simulator
(``true_step_rewards`` on the states robosuite reached with the same actions).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from poir_mjx.cached import builder
from poir_mjx.core import ensemble as ens
from poir_mjx.core.agent import POIR, POIRParams
from poir_mjx.core.config import REWARDS
from poir_mjx.core.scoring import step_rewards, variant


def nearest_expert(states: jax.Array, expert: jax.Array, chunk: int = 4096) -> jax.Array:
    """The nearest expert state of every query state (squared distance measured directly): [Q, d] -> [Q, d]."""
    chunk = min(chunk, expert.shape[0])
    n = -(-expert.shape[0] // chunk)
    pad = n * chunk - expert.shape[0]
    ex = jnp.concatenate([expert, jnp.full((pad, expert.shape[1]), jnp.inf, expert.dtype)]).reshape(n, chunk, -1)

    def body(best, e):
        d2 = jnp.sum((states[:, None, :] - e[None]) ** 2, -1)  # [Q, chunk]
        i = jnp.argmin(d2, -1)
        cand, cd2 = e[i], jnp.take_along_axis(d2, i[:, None], -1)[:, 0]
        better = cd2 < best[1]
        return (jnp.where(better[:, None], cand, best[0]), jnp.where(better, cd2, best[1])), None

    init = (jnp.zeros_like(states), jnp.full(states.shape[0], jnp.inf, states.dtype))
    (near, _), _ = jax.lax.scan(body, init, ex)
    return near


@builder(maxsize=8)
def call_fn(agent: POIR):
    """jit((params, obs, key) -> dict): one planner call of `agent` (its own reward and selection) taken apart.

    returns_<r> [K, M]: each reward's model return of the same candidates (-inf on padding); actions [H, K, M, da] and
    states [H + 1, K, M, ds] (normalised); plan / ebc [da]: the planner's action and EBC's (the prior's mean), env
    units; first_env [K, M, da]: the candidates' first actions in env units; scored [H, K, M, ds]: the states L2 and DRIL score; l2_near: their nearest expert states; dril_heads
    [K, H, K, M, da]: every BC head's action there; morel_heads [K, H, K, M, ds]: every world-model head's
    prediction from (s_t, a_t).
    """

    def fn(params, obs, key):
        imag = agent.imagine(params, obs, key)
        out = {f"returns_{r}": _returns(agent, r, params, imag) for r in REWARDS}
        out.update(actions=imag.actions, states=imag.states,
                   plan=agent._to_env_action(params, agent.select(imag.returns, imag.actions[0], key)),
                   ebc=agent.ebc_action(params, obs), first_env=agent._to_env_action(params, imag.actions[0]))  # fmt: skip
        scored = imag.states[1:] if variant(agent, "dril").scores_next_state() else imag.states[:-1]
        flat = scored.reshape(-1, agent.obs_size)
        out["scored"] = scored
        out["l2_near"] = nearest_expert(flat, params.expert_states).reshape(scored.shape)
        out["dril_heads"] = agent._bc_all(params, scored)
        sa = jnp.concatenate([imag.states[:-1], imag.actions], -1)
        out["morel_heads"] = imag.states[:-1] + ens.apply_all(agent.wm_module, params.reward_wm, sa)
        return out

    return jax.jit(fn)


def _returns(agent: POIR, reward: str, params: POIRParams, imag) -> jax.Array:
    k, m = agent.head_layout()
    real = jnp.arange(k)[:, None] + k * jnp.arange(m)[None, :] < agent.config.planner.num_trajectories
    return jnp.where(real, step_rewards(agent, reward, params, imag.states, imag.actions).sum(0), -jnp.inf)


@builder(maxsize=8)
def plan_fn(agent: POIR):
    """jit(agent.plan), one per agent config: every diagnosed episode drives with the same compiled planner (a new
    ``jax.jit(agent.plan)`` per episode would trace and compile it again)."""
    return jax.jit(agent.plan)


@builder(maxsize=8)
def true_rewards_fn(agent: POIR):
    """jit((params, obs [H + 1, N, ds] raw, actions [H, N, da] normalised) -> {reward: [H, N]}): each reward of the
    states the true simulator reached."""

    def fn(params, obs, actions):
        s = agent.normalize_obs(params, obs)
        return {r: step_rewards(agent, r, params, s, actions) for r in REWARDS}

    return jax.jit(fn)


@builder(maxsize=8)
def one_step_error_fn(agent: POIR):
    """jit((params, obs [Q, ds], act [Q, da], next_obs [Q, ds], all raw) -> [ds]): the world model's one-step squared
    error per normalised dimension, averaged over its heads and the rows (the prediction as the planner makes it)."""

    def fn(params, obs, act, next_obs):
        s, s2 = agent.normalize_obs(params, obs), agent.normalize_obs(params, next_obs)
        a = params.act_norm(jnp.asarray(act, jnp.float32))
        pred = agent._clip(s + ens.apply_all(agent.wm_module, params.wm, jnp.concatenate([s, a], -1)))
        return jnp.mean((pred - s2[None]) ** 2, axis=(0, 1))

    return jax.jit(fn)
