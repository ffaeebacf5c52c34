"""The off-policy baselines' toy task: the point mass with a y drift, and demonstrations from an expert that knows it.

Success: the episode ENDS (step HORIZON) with x >= 1 and |y| < 0.05. The start y ~ N(0, 0.2), the drift of 0.03 a
step (0.45 over an episode) and the action noise push y out of the band unless the policy steers it back from wherever
it is and holds it there (crossing the band once by chance, which the point mass's own "any step" success counts, does
not count here); a constant action ([0.2, -0.03]) succeeds in 6 of 32 evaluation episodes. The expert moves +0.2 in x,
cancels the drift and halves y each step; its demonstrations are recorded under more action noise (0.05) than the
training and evaluation episodes (0.01), so they show its corrections away from the band's centre. Its success: 32/32.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.baselines.learner import ExpertData
from poir_mjx.baselines.offpolicy import LoopConfig
from poir_mjx.envs.env import make_params
from poir_mjx.rollout.evaluator import make_evaluator
from poir_mjx.rollout.episode import batched_episodes, stateless
from tests.helpers import PointMassEnv

HORIZON = 15
DRIFT = 0.03


@dataclasses.dataclass(frozen=True)
class HoldEnv(PointMassEnv):
    """PointMassEnv whose success counts at the last step only."""

    def step(self, state, action):
        nxt = super().step(state, action)
        success = nxt.success & (nxt.info["step"] >= self.horizon)
        first = jnp.where((state.info["first_success"] < 0) & success, nxt.info["step"], state.info["first_success"])
        new = nxt.replace(success=success, info=dict(nxt.info, first_success=first))
        return jax.tree_util.tree_map(lambda old, nw: jnp.where(state.done, old, nw), state, new)


ENV = HoldEnv(drift_y=DRIFT, horizon=HORIZON)
PARAMS = make_params(0.2, 0.01)  # sigma_init (y only in the toy), sigma_action: training and evaluation
DEMO_PARAMS = make_params(0.2, 0.05)  # the demonstrations' larger action noise shows the expert's corrections


def loop_config(total_env_steps: int, updates_per_iteration: int) -> LoopConfig:
    """The toy's run: 8 environments, episodes of HORIZON steps, 240 warm-up steps, batches of 128."""
    return LoopConfig(num_envs=8, episode_steps=HORIZON, total_env_steps=total_env_steps, eval_every=total_env_steps,
                      warmup_steps=240, updates_per_iteration=updates_per_iteration, batch_size=128,
                      replay_capacity=8000)  # fmt: skip


def expert_action(params, obs, key):
    return jnp.array([0.2, jnp.clip(-0.5 * obs[1] - DRIFT, -1.0, 1.0)])


def expert_data(n_demos: int = 16, steps: int = HORIZON, seed: int = 0) -> ExpertData:
    """``n_demos`` expert episodes of ``steps`` transitions (each ends terminal, like a demonstration that stops)."""
    record = lambda s, a, s2: (ENV.obs_vector(s), a, ENV.obs_vector(s2))  # noqa: E731
    episodes = batched_episodes(ENV, stateless(ENV, expert_action), steps, record)
    keys = jax.random.split(jax.random.PRNGKey(1000 + seed), n_demos)
    _, (o, a, o2) = episodes(None, keys, broadcast(DEMO_PARAMS, n_demos))
    flat = lambda x: np.asarray(x, np.float32).reshape(n_demos * steps, -1)  # noqa: E731
    t = np.arange(n_demos * steps) % steps
    return ExpertData(obs=flat(o), actions=flat(a), next_obs=flat(o2), terminal=t == steps - 1, initial=t == 0)


def broadcast(params, n: int):
    return jax.tree_util.tree_map(lambda x: jnp.broadcast_to(x, (n,)), params)


def success_rate(learner, state, episodes: int = 32, seed: int = 7) -> float:
    """The deterministic policy's success rate over ``episodes`` fresh episodes (the project's evaluator)."""
    evaluate = make_evaluator(ENV, learner.policy_fn(), HORIZON)
    out = evaluate(learner.policy_params(state), jax.random.split(jax.random.PRNGKey(seed), episodes),
                   broadcast(PARAMS, episodes))  # fmt: skip
    return float(np.mean(np.asarray(out["first_success"]) >= 0))


def expert_success_rate(episodes: int = 32, seed: int = 7) -> float:
    evaluate = make_evaluator(ENV, expert_action, HORIZON)
    out = evaluate(None, jax.random.split(jax.random.PRNGKey(seed), episodes), broadcast(PARAMS, episodes))
    return float(np.mean(np.asarray(out["first_success"]) >= 0))
