"""The oracle control (issue 41): the planner's own candidates, ranked by their returns in the true simulator.

At every control step the POIR agent imagines its N candidate action sequences as usual (same prior, noise and key);
instead of scoring them in its world model, each sequence is rolled out in the true simulator from the episode's
current state, and the imitation reward of the states it really reaches is summed. The top-k of those true returns
choose the action. No ranking of the same candidates by the same reward can do better in expectation, so the cell
bounds what a better world model or scoring could buy. It costs N x H environment steps per control step: in MJX the
rollouts run inside the compiled policy (``oracle_policy``); in robosuite each worker rolls its episodes' candidates
out from their restored states (``RobosuiteOracle``, ``eval/robosuite_state.py``), about N x H robosuite steps of
one core per control step: a few episodes per cell.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.cached import builder
from poir_mjx.core import selection as sel
from poir_mjx.core.agent import POIR
from poir_mjx.core.scoring import step_rewards
from poir_mjx.rollout.episode import Policy
from poir_mjx.rollout.protocol import Env


def candidates(agent: POIR, params, obs: jax.Array, key: jax.Array) -> tuple[jax.Array, jax.Array]:
    """The planner's candidates at `obs` for `key`: (normalised [H, K, M, da], env units [K M, H, da])."""
    actions = agent.imagine(params, obs, key).actions
    h, k, m, da = actions.shape
    return actions, jnp.swapaxes(agent._to_env_action(params, actions.reshape(h, k * m, da)), 0, 1)


def returns_of_reached(agent: POIR, params, obs: jax.Array, reached: jax.Array, actions: jax.Array) -> jax.Array:
    """The true returns [K, M] (-inf on padding) of candidates `actions` [H, K, M, da] (normalised) whose rollouts from
    observation `obs` reached `reached` [H, K M, ds], under the agent's reward."""
    h, k, m, da = actions.shape
    start = jnp.broadcast_to(obs, reached.shape[1:])[None]
    states = agent.normalize_obs(params, jnp.concatenate([start, reached]))
    ret = step_rewards(agent, agent.config.planner.reward, params, states, actions.reshape(h, k * m, da))
    ret = ret.sum(0).reshape(k, m)
    return jnp.where(sel.real_mask(k, m, agent.config.planner.num_trajectories), ret, -jnp.inf)


def choose(agent: POIR, params, ret: jax.Array, actions: jax.Array, key: jax.Array) -> jax.Array:
    """The env action: the mean first action of the top_k true returns."""
    pc = agent.config.planner
    return agent._to_env_action(params, sel.select("top_k", ret, actions[0], key, pc.num_trajectories, pc.top_k))


def true_returns(env: Env, agent: POIR, params, state, actions: jax.Array) -> jax.Array:
    """Candidate actions [H, K, M, da] (normalised) rolled out in `env` from `state`; their true returns [K, M]
    under the agent's reward (-inf on padding)."""
    h, k, m, da = actions.shape
    env_actions = agent._to_env_action(params, actions.reshape(h, k * m, da))

    def rollout(seq):  # [H, da] -> the observations reached [H, ds]
        def body(s, a):
            s = env.step(s, a)
            return s, env.obs_vector(s)

        return jax.lax.scan(body, state, seq)[1]

    reached = jax.vmap(rollout, in_axes=1, out_axes=1)(env_actions)  # [H, K M, ds]
    return returns_of_reached(agent, params, env.obs_vector(state), reached, actions)


def oracle_policy(env: Env, agent: POIR) -> Policy:
    """A rollout policy (MJX): the planner's candidates for the step's key, the top_k of their true returns."""

    def act(params, carry, state, key):
        imag = agent.imagine(params, env.obs_vector(state), key)
        return choose(agent, params, true_returns(env, agent, params, state, imag.actions), imag.actions, key), carry

    return Policy(act=act)


class RobosuiteOracle:
    """The oracle in robosuite's evaluator (``eval/robosuite_eval.py``): per control step, the batch's candidates are
    proposed (compiled), rolled out by the workers from their episodes' restored states (``RobosuitePool.probe``),
    and the top_k of their true returns chosen (compiled). Episodes that have ended are not rolled out."""

    probes = True  # robosuite_eval: call with the pool, not as a policy function

    def __init__(self, agent: POIR):
        self.propose = _compiled_propose(agent)
        self.pick = _compiled_pick(agent)

    def __call__(self, pool, wids, settled: np.ndarray, params, obs: jax.Array, keys: jax.Array) -> jax.Array:
        actions, env_actions = self.propose(params, obs, keys)
        reached = pool.probe(wids, np.asarray(env_actions), settled)  # [B, H, K M, ds]
        return self.pick(params, obs, jnp.asarray(reached), actions, keys)


@builder(maxsize=8)
def _compiled_propose(agent: POIR):
    """The batch's candidates, compiled once per agent config."""
    return jax.jit(jax.vmap(functools.partial(candidates, agent), in_axes=(None, 0, 0)))


@builder(maxsize=8)
def _compiled_pick(agent: POIR):
    """The batch's true returns -> actions, compiled once per agent config."""

    def pick(params, obs, reached, actions, key):
        return choose(agent, params, returns_of_reached(agent, params, obs, reached, actions), actions, key)

    return jax.jit(jax.vmap(pick, in_axes=(None, 0, 0, 0, 0)))
