"""The oracle control (issue 41): the planner's own candidates, ranked by their returns in the true simulator.

At every control step the POIR agent imagines its N candidate action sequences as usual (same prior, noise and key);
instead of scoring them in its world model, each sequence is rolled out in the MJX environment itself from the
episode's current state, and the imitation reward of the states it really reaches is summed. The top-k of those true
returns choose the action. No ranking of the same candidates by the same reward can do better in expectation, so
the cell bounds what a better world model or scoring could buy. MJX only (it needs the simulator's state inside the
policy); it costs N x H environment steps per control step: a GPU control, a few episodes per cell.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from poir_mjx.core import selection as sel
from poir_mjx.core.agent import POIR
from poir_mjx.core.scoring import step_rewards
from poir_mjx.rollout.episode import Policy
from poir_mjx.rollout.protocol import Env


def true_returns(env: Env, agent: POIR, params, state, actions: jax.Array) -> jax.Array:
    """Candidate actions [H, K, M, da] (normalised) rolled out in `env` from `state`; their true returns [K, M]
    under the agent's reward (-inf on padding)."""
    h, k, m, da = actions.shape
    flat = actions.reshape(h, k * m, da)
    env_actions = agent._to_env_action(params, flat)

    def rollout(seq):  # [H, da] -> the observations reached [H, ds]
        def body(s, a):
            s = env.step(s, a)
            return s, env.obs_vector(s)

        return jax.lax.scan(body, state, seq)[1]

    reached = jax.vmap(rollout, in_axes=1, out_axes=1)(env_actions)  # [H, K M, ds]
    start = jnp.broadcast_to(env.obs_vector(state), reached.shape[1:])[None]
    states = agent.normalize_obs(params, jnp.concatenate([start, reached]))
    ret = step_rewards(agent, agent.config.planner.reward, params, states, flat).sum(0).reshape(k, m)
    return jnp.where(sel.real_mask(k, m, agent.config.planner.num_trajectories), ret, -jnp.inf)


def oracle_policy(env: Env, agent: POIR) -> Policy:
    """A rollout policy: the planner's candidates for the step's key, the top_k of their true returns."""
    pc = agent.config.planner

    def act(params, carry, state, key):
        imag = agent.imagine(params, env.obs_vector(state), key)
        ret = true_returns(env, agent, params, state, imag.actions)
        a = sel.select("top_k", ret, imag.actions[0], key, pc.num_trajectories, pc.top_k)
        return agent._to_env_action(params, a), carry

    return Policy(act=act)
