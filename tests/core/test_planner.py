import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx.core.agent import POIR, top_k_mean
from poir_mjx.core.rewards import l2_reward
from tests.helpers import SMALL, expert_data



def test_top_k_mean_and_argmax():
    ret = jnp.array([0.0, 5.0, 3.0, 4.0])
    acts = jnp.arange(8.0).reshape(4, 2)
    np.testing.assert_array_equal(top_k_mean(ret, acts, 1), acts[1])
    np.testing.assert_allclose(top_k_mean(ret, acts, 2), (acts[1] + acts[3]) / 2)


@pytest.mark.parametrize("n,k", [(10, 3), (9, 3), (1, 3), (4000, 27)])
def test_round_robin_heads_cover_n_trajectories(n, k):
    cfg = dataclasses.replace(SMALL, ensemble_size=k, planner=dataclasses.replace(SMALL.planner, num_trajectories=n, top_k=1))
    kk, m = POIR(cfg, 2, 2).head_layout()
    assert kk == k and k * m >= n > k * (m - 1)
    # trajectory n sits at [n mod K, n // K]: each head gets ceil or floor of N/K trajectories
    idx = np.arange(k)[:, None] + k * np.arange(m)[None, :]
    counts = (idx < n).sum(1)
    assert counts.sum() == n and counts.max() - counts.min() <= 1
    assert np.all(counts == [len(range(h, n, k)) for h in range(k)])


@pytest.fixture(scope="module")
def trained():
    obs, act, nxt = expert_data()
    agent = POIR(SMALL, 2, 2)
    params, hist = agent.fit(jax.random.PRNGKey(0), obs, act, nxt)
    return agent, params, hist, obs


def test_training_reduces_loss(trained):
    _, _, hist, _ = trained
    assert hist["bc"].shape == (SMALL.train.epochs, SMALL.ensemble_size)
    assert np.all(hist["wm"][-1] < 0.2 * hist["wm"][0])
    assert np.all(hist["bc"][-1] < hist["bc"][0])


def test_padding_trajectories_never_win(trained):
    agent, params, _, _ = trained
    cfg = dataclasses.replace(SMALL, planner=dataclasses.replace(SMALL.planner, num_trajectories=7, top_k=7))
    ret, first = POIR(cfg, 2, 2).rollouts(params, jnp.array([0.2, 0.3]), jax.random.PRNGKey(0))
    assert ret.shape == (3, 3)
    assert np.isinf(np.asarray(ret)).sum() == 2  # 9 cells, 7 trajectories
    assert np.isfinite(np.asarray(ret)).sum() == 7


def test_poir_returns_to_the_expert_support_better_than_ebc(trained):
    agent, params, _, expert_obs = trained
    plan = jax.jit(jax.vmap(agent.plan, in_axes=(None, 0, 0)))
    ebc = jax.jit(jax.vmap(agent.ebc_action, in_axes=(None, 0)))
    starts = jnp.array([[0.1, 0.5], [0.3, -0.5], [0.2, 0.6], [0.4, -0.4]], jnp.float32)
    s_poir, s_ebc = starts, starts
    key = jax.random.PRNGKey(1)
    for t in range(15):
        keys = jax.random.split(jax.random.fold_in(key, t), starts.shape[0])  # one key per episode
        s_poir = s_poir + plan(params, s_poir, keys)
        s_ebc = s_ebc + ebc(params, s_ebc)
    e = jnp.asarray(expert_obs)
    d0 = -np.asarray(l2_reward(starts, e))
    d_poir = -np.asarray(l2_reward(s_poir, e))
    d_ebc = -np.asarray(l2_reward(s_ebc, e))
    print("start", d0.round(3), "EBC", d_ebc.round(3), "POIR", d_poir.round(3))
    assert d_poir.mean() < 0.5 * d_ebc.mean()
    assert np.all(d_poir < d0)


def test_no_prior_ablation_samples_uniformly_in_bounds(trained):
    _, params, _, _ = trained
    cfg = dataclasses.replace(SMALL, planner=dataclasses.replace(SMALL.planner, use_prior=False))
    agent = POIR(cfg, 2, 2)
    _, first = agent.rollouts(params, jnp.zeros(2), jax.random.PRNGKey(0))
    raw = np.asarray(params.act_norm.inverse(first))
    assert raw.min() >= -1 - 1e-5 and raw.max() <= 1 + 1e-5
    assert raw.std() > 0.3  # uniform in [-1, 1] has std 0.58, the prior's actions far less
    a = np.asarray(agent.plan(params, jnp.zeros(2), jax.random.PRNGKey(0)))
    assert np.all(np.abs(a) <= 1.0)


def _timing_agent(reward, timing, horizon=1):
    planner = dataclasses.replace(SMALL.planner, reward=reward, horizon=horizon, reward_timing=timing)
    return POIR(dataclasses.replace(SMALL, planner=planner), 2, 2)


@pytest.mark.parametrize("reward", ["l2", "dril"])
def test_next_state_timing_scores_the_state_each_action_leads_to(trained, reward):
    """H = 1: the return of each trajectory is the reward of the predicted next state of its own head."""
    from poir_mjx.core import ensemble as ens
    from poir_mjx.core.rewards import dril_reward

    _, params, _, _ = trained
    agent = _timing_agent(reward, "next_state")
    obs = jnp.array([0.3, 0.25])
    ret, first = agent.rollouts(params, obs, jax.random.PRNGKey(3))
    s0 = jnp.broadcast_to(params.obs_norm(obs), first.shape[:-1] + (2,))
    s1 = s0 + ens.apply_each(agent.wm_module, params.wm, jnp.concatenate([s0, first], -1))
    if reward == "l2":
        expect = l2_reward(s1.reshape(-1, 2), params.expert_states).reshape(s1.shape[:-1])
    else:
        expect = dril_reward(ens.apply_all(agent.bc_module, params.bc, s1))
    ok = np.isfinite(np.asarray(ret))
    np.testing.assert_allclose(np.asarray(ret)[ok], np.asarray(expect)[ok], rtol=1e-5, atol=1e-5)
    assert np.ptp(np.asarray(ret)[ok]) > 1e-3  # the returns rank the actions


@pytest.mark.parametrize("reward", ["l2", "dril"])
def test_current_state_timing_is_the_printed_algorithm(trained, reward):
    """The ablation: r(s_1, a_1) at H = 1 is the same for every trajectory, so all returns tie."""
    _, params, _, _ = trained
    ret, _ = _timing_agent(reward, "current_state").rollouts(params, jnp.array([0.3, 0.25]), jax.random.PRNGKey(3))
    r = np.asarray(ret)[np.isfinite(np.asarray(ret))]
    np.testing.assert_allclose(r, r[0], rtol=1e-6)


def test_morel_keeps_scoring_the_transition_it_starts(trained):
    _, params, _, _ = trained
    obs = jnp.array([0.3, 0.25])
    a = _timing_agent("morel", "next_state").rollouts(params, obs, jax.random.PRNGKey(3))
    b = _timing_agent("morel", "current_state").rollouts(params, obs, jax.random.PRNGKey(3))
    np.testing.assert_array_equal(np.asarray(a[0]), np.asarray(b[0]))
    assert np.ptp(np.asarray(a[0])[np.isfinite(np.asarray(a[0]))]) > 0
