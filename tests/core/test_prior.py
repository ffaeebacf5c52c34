"""The prior's spaces (config.bc_space), the controls (prior alone, random selection), the "excess"
disagreement rewards, and the planner's selection of real trajectories only."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx.core import ensemble as ens
from poir_mjx.core import rewards
from poir_mjx.core.agent import POIR
from poir_mjx.core.config import MLPConfig, NormalizerConfig, TrainConfig
from tests.helpers import expert_data, tiny_config

CFG = tiny_config()
OBS = jnp.array([0.3, 0.02], jnp.float32)


def _fit(cfg, **kw):
    agent = POIR(cfg, 2, 2)
    return agent, agent.fit(jax.random.PRNGKey(0), *expert_data(n_demos=8, steps=10), **kw)[0]


def _with(cfg=CFG, **planner):
    return dataclasses.replace(cfg, planner=dataclasses.replace(cfg.planner, **planner))


def test_raw_prior_is_ebcs_ensemble_bit_for_bit():
    """bc_space "raw": a POIR agent's BC heads are the policy agent's (same seed), so its prior alone is EBC."""
    policy, p_policy = _fit(dataclasses.replace(CFG, normalize=False), train_world_model=False)
    poir, p_poir = _fit(dataclasses.replace(CFG, bc_space="raw"))
    for a, b in zip(jax.tree_util.tree_leaves(p_policy.bc), jax.tree_util.tree_leaves(p_poir.bc)):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(policy.ebc_action(p_policy, OBS), poir.ebc_action(p_poir, OBS))
    np.testing.assert_array_equal(policy.bc_action(p_policy, OBS), poir.bc_action(p_poir, OBS))
    _, p_norm = _fit(dataclasses.replace(CFG, bc_space="normalized"))
    assert not np.allclose(jax.tree_util.tree_leaves(p_norm.bc)[0], jax.tree_util.tree_leaves(p_poir.bc)[0])
    # So the policy's heads can stand in for training them again: every parameter comes out the same.
    _, p_reused = _fit(dataclasses.replace(CFG, bc_space="raw"), bc_params=p_policy.bc)
    for a, b in zip(jax.tree_util.tree_leaves(p_poir), jax.tree_util.tree_leaves(p_reused), strict=True):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError, match="bc_params"):
        _fit(dataclasses.replace(CFG, bc_space="normalized"), bc_params=p_policy.bc)


@pytest.mark.parametrize("space", ["normalized", "weighted", "raw"])
def test_planner_without_noise_averages_the_priors_heads(space):
    """sigma 0 and top_k = N (a multiple of K): the planned action is the prior's mean action, whatever
    space the heads were trained in, so the planner converts raw heads to its normalised spaces correctly."""
    agent, params = _fit(_with(dataclasses.replace(CFG, bc_space=space), sigma=0.0, top_k=12))
    np.testing.assert_allclose(agent.plan(params, OBS, jax.random.PRNGKey(1)), agent.ebc_action(params, OBS),
                               rtol=1e-5, atol=1e-6)  # fmt: skip


def test_weighted_loss_is_the_squared_error_in_action_units():
    """train_epoch's weights scale each output dimension's squared error (learning rate 0: the loss of
    the initial networks), and "weighted" uses the actions' variance, which the raw space's loss equals."""
    module = ens.make_mlp(MLPConfig(layers=2, width=8), 2)
    x = jax.random.normal(jax.random.PRNGKey(0), (64, 3))
    y = jax.random.normal(jax.random.PRNGKey(1), (64, 2)) * jnp.array([1.0, 5.0])
    opt = ens.make_optimizer(TrainConfig(learning_rate=0.0))
    st = ens.init_train_state(ens.init_ensemble(module, jax.random.PRNGKey(2), 2, 3), opt)
    w = jnp.array([0.5, 2.0])
    _, loss = ens.train_epoch(module, opt, 64, st, x, y, jax.random.PRNGKey(3), w)
    pred = ens.apply_all(module, st.params, x)
    np.testing.assert_allclose(loss, jnp.mean(jnp.sum(w * (pred - y) ** 2, -1), -1), rtol=1e-5)
    assert ens.make_optimizer(TrainConfig(learning_rate=0.0)) is opt  # one optimizer per config: one compile


def test_real_trajectories_only_are_selected():
    """Padding cells (n >= N) never enter the average, even where real returns are NaN or -inf and
    top_k reaches past the finite ones; the order is n = k + K j."""
    agent = POIR(_with(num_trajectories=7, top_k=7), 2, 2)
    ret = jnp.array([[1.0, 2.0, 3.0], [4.0, 5.0, -jnp.inf], [6.0, jnp.nan, -jnp.inf]])  # [K=3, M=3]
    first = jnp.arange(18.0).reshape(3, 3, 2)
    r, f = agent.real_trajectories(ret, first)
    np.testing.assert_array_equal(r[:6], [1.0, 4.0, 6.0, 2.0, 5.0, np.nan])
    np.testing.assert_array_equal(f, first.transpose(1, 0, 2).reshape(-1, 2)[:7])
    real = np.asarray(first).transpose(1, 0, 2).reshape(-1, 2)[:7]
    np.testing.assert_allclose(agent.select(ret, first, jax.random.PRNGKey(0)), real.mean(0))


def test_random_selection_ignores_the_returns():
    agent = POIR(_with(num_trajectories=12, top_k=3, selection="random"), 2, 2)
    first = jax.random.normal(jax.random.PRNGKey(4), (3, 4, 2))
    key = jax.random.PRNGKey(5)
    a = agent.select(jnp.arange(12.0).reshape(3, 4), first, key)
    b = agent.select(-jnp.arange(12.0).reshape(3, 4), first, key)
    np.testing.assert_array_equal(a, b)  # the same draw whatever the ranking
    chosen = set()
    for i in range(40):
        pick = np.asarray(agent.select(jnp.zeros((3, 4)), first, jax.random.PRNGKey(i)))
        chosen.add(tuple(pick.round(5)))
    assert len(chosen) > 20  # draws differ across keys
    top = POIR(_with(num_trajectories=12, top_k=3), 2, 2).select(jnp.arange(12.0).reshape(3, 4), first, key)
    real = np.asarray(first).transpose(1, 0, 2).reshape(-1, 2)
    np.testing.assert_allclose(top, real[[5, 8, 11]].mean(0), rtol=1e-6)  # returns 9-11 sit at [2, 1..3]


@pytest.fixture(scope="module")
def fitted():
    return _fit(dataclasses.replace(CFG, bc_space="normalized"))  # the heads as the rewards see them


def test_disagreement_levels_are_the_expert_datas_quantiles(fitted):
    agent, params = fitted
    obs, act, _ = expert_data(n_demos=8, steps=10)
    s, a = params.obs_norm(obs), params.act_norm(act)
    d_bc = -np.asarray(rewards.dril_reward(ens.apply_all(agent.bc_module, params.bc, s)))
    d_wm = -np.asarray(rewards.morel_reward(ens.apply_all(agent.wm_module, params.wm, jnp.concatenate([s, a], -1))))
    np.testing.assert_allclose(params.dril_level, np.quantile(d_bc, 0.98), rtol=1e-5)
    np.testing.assert_allclose(params.morel_level, np.quantile(d_wm, 0.98), rtol=1e-5)
    assert 0 < params.dril_level and 0 < params.morel_level


@pytest.mark.parametrize("reward", ["dril", "morel"])
def test_excess_reward_ties_states_as_certain_as_the_experts(fitted, reward):
    agent, params = fitted
    s = jax.random.normal(jax.random.PRNGKey(6), (3, 5, 2)) * 3.0
    a = jax.random.normal(jax.random.PRNGKey(7), (3, 5, 2))
    cfg = agent.config
    raw = POIR(_with(cfg, reward=reward), 2, 2).trajectory_rewards(params, s, a)
    rel = POIR(_with(cfg, reward=reward, disagreement="excess"), 2, 2).trajectory_rewards(params, s, a)
    level = params.dril_level if reward == "dril" else params.morel_level
    np.testing.assert_allclose(rel, np.minimum(np.asarray(raw) + float(level), 0.0), rtol=1e-6)
    assert np.any(np.asarray(rel) == 0.0) and np.any(np.asarray(rel) < 0.0)
    np.testing.assert_array_equal(rewards.excess(jnp.array([-3.0, -0.5, 0.0]), 1.0), [-2.0, 0.0, 0.0])


def test_morel_scores_the_clipped_predictions_the_rollout_uses():
    cfg = dataclasses.replace(_with(reward="morel"), normalizer=NormalizerConfig(clip=0.5))
    agent, params = _fit(cfg)
    s = jnp.full((3, 4, 2), 0.45)
    a = jax.random.normal(jax.random.PRNGKey(8), (3, 4, 2)) * 2.0
    deltas = ens.apply_all(agent.wm_module, params.reward_wm, jnp.concatenate([s, a], -1))
    clipped = rewards.morel_reward(jnp.clip(s + deltas, -0.5, 0.5))
    np.testing.assert_allclose(agent.trajectory_rewards(params, s, a), clipped, rtol=1e-6)
    assert not np.allclose(clipped, rewards.morel_reward(deltas))  # the clip matters here


@pytest.mark.parametrize("reward", ["dril", "morel"])
def test_head_chunks_bound_memory_not_the_result(fitted, reward):
    """planner.head_chunk applies the rewards' heads a few at a time: the same rewards, less memory held."""
    agent, params = fitted
    k = dataclasses.replace(agent.config, ensemble_size=9)
    agent9 = POIR(k, 2, 2)
    params9, _ = agent9.fit(jax.random.PRNGKey(2), *expert_data(n_demos=8, steps=10))
    s = jax.random.normal(jax.random.PRNGKey(9), (9, 400, 2))
    a = jax.random.normal(jax.random.PRNGKey(10), (9, 400, 2))

    def rewards_fn(chunk):
        ag = POIR(_with(k, reward=reward, head_chunk=chunk), 2, 2)
        return jax.jit(ag.trajectory_rewards)

    full, chunked = rewards_fn(0), rewards_fn(1)
    np.testing.assert_allclose(chunked(params9, s, a), full(params9, s, a), rtol=1e-5, atol=1e-6)
    mem = [f.lower(params9, s, a).compile().memory_analysis().temp_size_in_bytes for f in (full, chunked)]
    assert mem[1] < mem[0] / 2, mem
