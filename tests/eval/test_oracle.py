"""The oracle control on the point mass (whose true drift the world model never saw): the candidates are the
planner's own, their returns those of the states the environment really reaches."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx.core.agent import POIR
from poir_mjx.core.config import ConfigError
from poir_mjx.core.scoring import step_rewards
from poir_mjx.envs.env import make_params
from poir_mjx.eval.episodes import run_episodes
from poir_mjx.eval.methods import get_method
from poir_mjx.eval.oracle import oracle_policy, true_returns
from poir_mjx.rollout.evaluator import episode_keys, make_evaluator
from tests.helpers import SMALL, PointMassEnv, expert_data

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


def test_the_oracle_methods_refuse_robosuite():
    m = get_method("POIR-L2 oracle")
    assert m.oracle and m.reward == "l2" and get_method("POIR-DRIL oracle").reward == "dril"
    with pytest.raises(ConfigError, match="use simulator 'mjx'"):
        run_episodes("robosuite", "lift", m, None, None, None, [0.02], [0.0], 5)


def test_a_sweep_refuses_an_oracle_method_outside_mjx(tmp_path):
    import json

    from poir_mjx.sweep.config import load_sweep_config

    path = tmp_path / "c.json"
    path.write_text(json.dumps({"name": "o", "methods": ["EBC", "POIR-L2 oracle"], "simulator": "robosuite"}))
    with pytest.raises(ConfigError, match=r"c.json: .*POIR-L2 oracle ranks by returns in the true simulator"):
        load_sweep_config(path)
    path.write_text(json.dumps({"name": "o", "methods": ["EBC", "POIR-L2 oracle"], "simulator": "mjx"}))
    assert load_sweep_config(path).methods == ("EBC", "POIR-L2 oracle")
