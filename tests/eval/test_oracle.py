"""The oracle control on the point mass (whose true drift the world model never saw): the candidates are the
planner's own, their returns those of the states the environment really reaches."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx.core.agent import POIR
from poir_mjx.core.scoring import step_rewards
from poir_mjx.envs.env import make_params
from poir_mjx.eval.episodes import run_episodes
from poir_mjx.eval.methods import get_method
from poir_mjx.eval.oracle import oracle_policy, true_returns
from poir_mjx.rollout.evaluator import episode_keys, make_evaluator
from tests.helpers import SMALL, PointMassEnv, expert_data, tiny_config

ENV = PointMassEnv(drift_y=0.03)


@pytest.fixture(scope="module")
def trained():
    obs, act, nxt = expert_data()
    cfg = dataclasses.replace(SMALL, planner=dataclasses.replace(SMALL.planner, num_trajectories=10, top_k=1))
    agent = POIR(cfg, 2, 2)
    params, _ = agent.fit(jax.random.PRNGKey(0), obs, act, nxt)
    return agent, params


def test_true_returns_are_the_rewards_of_the_states_the_environment_reaches(trained):
    agent, params = trained
    state = ENV.reset(jax.random.PRNGKey(1), make_params(0.05, 0.0))
    imag = agent.imagine(params, ENV.obs_vector(state), jax.random.PRNGKey(2))
    got = np.asarray(true_returns(ENV, agent, params, state, imag.actions))
    h, k, m, _ = imag.actions.shape
    for i in range(k):
        for j in range(m):
            if i + k * j >= agent.config.planner.num_trajectories:
                assert np.isneginf(got[i, j])
                continue
            s, seen = state, [ENV.obs_vector(state)]
            for t in range(h):
                s = ENV.step(s, agent._to_env_action(params, imag.actions[t, i, j]))
                seen.append(ENV.obs_vector(s))
            states = agent.normalize_obs(params, jnp.stack(seen))
            want = step_rewards(agent, "l2", params, states, imag.actions[:, i, j]).sum()
            np.testing.assert_allclose(got[i, j], want, rtol=1e-5, atol=1e-5)
    # the drift makes the true ranking differ from the model's somewhere in the grid of candidates
    assert not np.allclose(got[np.isfinite(got)], np.asarray(imag.returns)[np.isfinite(got)])


def test_the_oracle_acts_with_the_best_true_candidate_and_runs_as_an_evaluator(trained):
    agent, params = trained
    state = ENV.reset(jax.random.PRNGKey(1), make_params(0.05, 0.0))
    key = jax.random.PRNGKey(3)
    action, _ = oracle_policy(ENV, agent).act(params, None, state, key)
    imag = agent.imagine(params, ENV.obs_vector(state), key)
    ret = true_returns(ENV, agent, params, state, imag.actions)
    best = np.unravel_index(np.argmax(np.asarray(ret)), ret.shape)
    np.testing.assert_allclose(action, agent._to_env_action(params, imag.actions[0][best]), rtol=1e-6)
    out = make_evaluator(ENV, oracle_policy(ENV, agent), 5)(params, episode_keys(0, 2), make_params([0.05] * 2, [0.0] * 2))
    assert np.asarray(out["steps"]).tolist() == [5, 5]


@pytest.fixture(scope="module")
def lift_agent():
    """An agent of Lift's low-dim sizes (19, 7), fitted for one epoch on random data: the oracle does not need a good one."""
    rng = np.random.default_rng(0)
    obs, act = rng.normal(size=(64, 19)).astype(np.float32), rng.uniform(-1, 1, (64, 7)).astype(np.float32)
    agent = POIR(tiny_config(k=2, n=4, horizon=2, top_k=1, epochs=1, batch=32, reward="l2"), 19, 7)
    params, _ = agent.fit(jax.random.PRNGKey(0), obs, act, obs + 0.01 * rng.normal(size=obs.shape).astype(np.float32))
    return agent, params


@pytest.mark.needs_robosuite
def test_a_robosuite_probe_rolls_out_from_the_episode_and_leaves_it_as_it_was():
    """The worker's rollouts start from the episode's own state (a fresh environment stepped along the same actions
    reaches the same observations), skip what they are told to, and the episode then goes on bit for bit as an
    unprobed one does, its action noise included."""
    from poir_mjx.eval.robosuite_eval import RobosuitePool
    from poir_mjx.eval.robosuite_state import rollout_from, save
    from poir_mjx.eval.robosuite_worker import flat_obs, start_episode

    rng = np.random.default_rng(1)
    steps, seqs = rng.uniform(-0.5, 0.5, (3, 7)), rng.uniform(-0.5, 0.5, (2, 3, 2, 7))
    seqs[..., 6] = np.sign(seqs[..., 6])
    episodes = [(11, 0.1, 0.05), (12, 0.1, 0.05)]
    with RobosuitePool("lift", workers=1, envs_per_worker=2) as probed, \
            RobosuitePool("lift", workers=1, envs_per_worker=2) as plain:  # fmt: skip
        for pool in (probed, plain):
            pool.reset(episodes)
        for t, a in enumerate(steps):
            if t == 2:
                reached = probed.probe([0], seqs, np.array([False, True]))
            obs, _, _ = probed.step(np.stack([a, a]))
            want, _, _ = plain.step(np.stack([a, a]))
            np.testing.assert_array_equal(obs, want)
    assert reached.shape == (2, 2, 3, 19) and not reached[1].any()
    env, noise, _ = start_episode("lift", 11, 0.1)
    try:
        for a in steps[:2]:  # the worker adds the episode's action noise to every real step
            o, _, _, _ = env.step(a + 0.05 * noise.standard_normal(7))
        truth = rollout_from(env, save(env), flat_obs(o), seqs[0], flat_obs)[1:]
    finally:
        env.close()
    np.testing.assert_allclose(reached[0], truth, atol=1e-6)


@pytest.mark.needs_robosuite
def test_the_robosuite_oracle_acts_with_the_best_true_candidate_and_runs_as_an_evaluator(lift_agent):
    from poir_mjx.eval.oracle import RobosuiteOracle, candidates, returns_of_reached
    from poir_mjx.eval.robosuite_eval import RobosuitePool
    from poir_mjx.eval.robosuite_state import rollout_from, save
    from poir_mjx.eval.robosuite_worker import flat_obs, start_episode

    agent, params = lift_agent
    keys = jax.random.split(jax.random.PRNGKey(4), 2)
    with RobosuitePool("lift", workers=1, envs_per_worker=2) as pool:
        obs, _ = pool.reset([(21, 0.1, 0.0), (22, 0.1, 0.0)])
        got = np.asarray(RobosuiteOracle(agent)(pool, [0], np.zeros(2, bool), params, jnp.asarray(obs), keys))
    for j, seed in enumerate((21, 22)):
        actions, env_actions = candidates(agent, params, jnp.asarray(obs[j]), keys[j])
        env, _, first = start_episode("lift", seed, 0.1)
        try:
            reached = rollout_from(env, save(env), first, np.asarray(env_actions), flat_obs)[1:]
        finally:
            env.close()
        ret = np.asarray(returns_of_reached(agent, params, jnp.asarray(obs[j]), jnp.asarray(reached), actions))
        best = np.unravel_index(np.argmax(ret), ret.shape)  # top_k 1: the best true return's first action
        np.testing.assert_allclose(got[j], agent._to_env_action(params, actions[0][best]), rtol=1e-5, atol=1e-6)
    out = run_episodes("robosuite", "lift", get_method("POIR-L2 oracle"), agent, params, episode_keys(0, 2),
                       [0.02] * 2, [0.0] * 2, 2, workers=1, progress=False)  # fmt: skip
    assert np.asarray(out["steps"]).tolist() == [2, 2] and not np.asarray(out["diverged"]).any()


def test_a_sweep_takes_an_oracle_method_in_either_simulator(tmp_path):
    import json

    from poir_mjx.sweep.config import load_sweep_config

    path = tmp_path / "c.json"
    for simulator in ("robosuite", "mjx"):
        path.write_text(json.dumps({"name": "o", "methods": ["EBC", "POIR-L2 oracle"], "simulator": simulator}))
        assert load_sweep_config(path).methods == ("EBC", "POIR-L2 oracle")
