"""Networks, planner and rewards run in float32 whatever jax_enable_x64 is (MJX physics may run in float64)."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx.core import checkpoint, rewards
from poir_mjx.core.agent import POIR, top_k_mean
from poir_mjx.core.config import MLPConfig, PlannerConfig, POIRConfig, TrainConfig
from tests.helpers import expert_data, x64

CFG = POIRConfig(
    ensemble_size=2,
    bc=MLPConfig(layers=2, width=16),
    world_model=MLPConfig(layers=2, width=16),
    train=TrainConfig(epochs=2, batch_size=32, learning_rate=1e-3),
    planner=PlannerConfig(num_trajectories=8, horizon=2, sigma=0.5, top_k=2, reward="l2"),
)
OBS64 = np.array([0.2, 0.3], np.float64)


def _agent(**planner):
    return POIR(dataclasses.replace(CFG, planner=dataclasses.replace(CFG.planner, **planner)), 2, 2)


def _assert_float32(tree):
    leaves = jax.tree_util.tree_leaves(tree)
    assert leaves and all(leaf.dtype == jnp.float32 for leaf in leaves), {leaf.dtype for leaf in leaves}


def _fit_x64(agent):
    data = (x.astype(np.float64) for x in expert_data(n_demos=4, steps=10))
    with x64(True):
        return agent.fit(jax.random.PRNGKey(0), *data)


@pytest.fixture(scope="module")
def fitted():
    return _fit_x64(_agent())[0]


def test_fit_under_x64_gives_float32_params(fitted):
    _assert_float32(fitted)
    params, history = _fit_x64(POIR(dataclasses.replace(CFG, normalize=False), 2, 2))
    _assert_float32(params)
    assert {h.dtype for h in history.values()} == {np.dtype(np.float32)}


@pytest.mark.parametrize("reward,use_prior", [("l2", True), ("dril", True), ("morel", True), ("l2", False)])
def test_policies_under_x64_are_float32_and_equal_the_float32_mode(fitted, reward, use_prior):
    agent, key = _agent(reward=reward, use_prior=use_prior), jax.random.PRNGKey(3)
    outs = {}
    for enabled in (True, False):
        with x64(enabled):
            obs = jnp.asarray(OBS64)
            assert obs.dtype == (jnp.float64 if enabled else jnp.float32)
            policies = (agent.plan(fitted, obs, key), agent.ebc_action(fitted, obs), agent.bc_action(fitted, obs))
            outs[enabled] = (*policies, *agent.rollouts(fitted, obs, key))
    for a64, a32 in zip(outs[True], outs[False]):
        assert a64.dtype == a32.dtype == jnp.float32
        # The same float32 XLA program runs in both modes (random draws have an explicit float32 dtype),
        # so the results are bitwise equal.
        np.testing.assert_array_equal(a64, a32)


def test_checkpoint_loads_float32_whatever_was_saved(fitted, tmp_path):
    with x64(True):
        as64 = jax.tree_util.tree_map(lambda x: np.asarray(x, np.float64), fitted)
        path = checkpoint.save(tmp_path / "f64.ckpt", _agent(), as64, {"task": "toy"})
        _, params, _ = checkpoint.load(path)
        _assert_float32(params)


def test_nan_return_never_wins():
    acts = jnp.arange(8.0).reshape(4, 2)
    ret = jnp.array([0.0, jnp.nan, 3.0, 1.0])
    np.testing.assert_array_equal(top_k_mean(ret, acts, 1), acts[2])
    np.testing.assert_array_equal(top_k_mean(ret, acts, 2), (acts[2] + acts[3]) / 2)


def test_nan_head_does_not_reach_the_planned_action(fitted):
    # BC head 0 gives NaN actions, so its trajectories (n even) get NaN returns; head 1's are finite.
    bc = jax.tree_util.tree_map(lambda p: p.at[0].set(jnp.nan), fitted.bc)
    params = fitted.replace(bc=bc)
    agent = _agent()
    ret, _ = agent.rollouts(params, jnp.asarray(OBS64, jnp.float32), jax.random.PRNGKey(0))
    assert np.isnan(np.asarray(ret[0])).all() and np.isfinite(np.asarray(ret[1])).all()
    assert np.isfinite(np.asarray(agent.plan(params, jnp.asarray(OBS64, jnp.float32), jax.random.PRNGKey(0)))).all()


def test_l2_reward_distances_use_highest_precision():
    q, e = jnp.zeros((3, 4), jnp.float32), jnp.ones((10, 4), jnp.float32)
    text = str(jax.make_jaxpr(lambda q, e: rewards.l2_reward(q, e, 4))(q, e))
    assert text.count("dot_general") >= 1
    assert text.count("dot_general") == text.count("precision=(Precision.HIGHEST, Precision.HIGHEST)")
