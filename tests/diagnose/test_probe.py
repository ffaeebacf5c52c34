"""The compiled forensics on the point mass: the probe sees exactly the planner's own candidates and returns."""

import dataclasses

import jax
import numpy as np
import pytest

from poir_mjx.core.agent import POIR
from poir_mjx.core.scoring import variant
from poir_mjx.diagnose import probe
from tests.helpers import SMALL, expert_data


@pytest.fixture(scope="module")
def trained():
    obs, act, nxt = expert_data()
    agent = POIR(dataclasses.replace(SMALL, planner=dataclasses.replace(SMALL.planner, num_trajectories=62)), 2, 2)
    params, _ = agent.fit(jax.random.PRNGKey(0), obs, act, nxt)
    return agent, params, obs, act, nxt


def test_imagine_keeps_every_step_of_the_planners_own_trajectories(trained):
    agent, params, obs, _, _ = trained
    key = jax.random.PRNGKey(3)
    ret, first = agent.rollouts(params, obs[5], key)
    imag = agent.imagine(params, obs[5], key)
    np.testing.assert_array_equal(imag.returns, ret)
    np.testing.assert_array_equal(imag.actions[0], first)
    k, m = agent.head_layout()
    h = agent.config.planner.horizon
    assert imag.states.shape == (h + 1, k, m, 2) and imag.step_rewards.shape == (h, k, m)
    np.testing.assert_allclose(imag.states[0], np.broadcast_to(agent.normalize_obs(params, obs[5]), (k, m, 2)))
    real = np.isfinite(np.asarray(ret))
    np.testing.assert_allclose(np.asarray(imag.step_rewards.sum(0))[real], np.asarray(ret)[real], rtol=1e-5)


@pytest.mark.parametrize("reward", ["l2", "dril", "morel"])
def test_probe_scores_the_same_candidates_with_every_reward(trained, reward):
    """returns_<r> is what a planner with reward r returns for the same key: the rewards rank one candidate set."""
    agent, params, obs, _, _ = trained
    key = jax.random.PRNGKey(4)
    call = probe.call_fn(agent)(params, obs[7], key)
    ret, _ = variant(agent, reward).rollouts(params, obs[7], key)
    np.testing.assert_allclose(call[f"returns_{reward}"], ret, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(call["plan"], agent.plan(params, obs[7], key), rtol=1e-6)
    np.testing.assert_allclose(call["ebc"], agent.ebc_action(params, obs[7]), rtol=1e-6)


def test_true_rewards_of_the_imagined_states_are_the_model_returns(trained):
    """Fed the world model's own states as if the simulator had reached them, the 'true' returns are the model's."""
    agent, params, obs, _, _ = trained
    key = jax.random.PRNGKey(5)
    call = jax.tree_util.tree_map(np.asarray, probe.call_fn(agent)(params, obs[9], key))
    raw = np.asarray(params.obs_norm.inverse(call["states"]))  # [H + 1, K, M, ds]
    true = probe.true_rewards_fn(agent)(params, raw, call["actions"])
    for r, v in true.items():
        real = np.isfinite(call[f"returns_{r}"])
        np.testing.assert_allclose(np.asarray(v).sum(0)[real], call[f"returns_{r}"][real], rtol=1e-3, atol=1e-3)


def test_one_step_error_is_small_on_the_demos_and_large_off_them(trained):
    agent, params, obs, act, nxt = trained
    err = probe.one_step_error_fn(agent)
    on = np.asarray(err(params, obs, act, nxt))
    off = np.asarray(err(params, obs, act, nxt + np.array([0.0, 0.1], np.float32)))  # the y the model never saw
    assert on.shape == (2,) and off[1] > 10 * on[1]
