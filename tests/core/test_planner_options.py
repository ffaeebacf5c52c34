"""The planner's scoring, selection, gripper and DRIL-geometry options (issue 41): each changes what it says."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx.core import ensemble as ens
from poir_mjx.core import selection as sel
from poir_mjx.core.agent import POIR
from tests.helpers import SMALL, expert_data

K, M = 3, 4


def _layout():
    """Returns [K, M] where head 2's model is optimistic: every one of its trajectories outscores the others."""
    rng = np.random.default_rng(0)
    ret = rng.normal(0, 0.1, (K, M)) + np.array([0.0, 0.0, 5.0])[:, None]
    first = np.arange(K * M * 2, dtype=np.float32).reshape(K, M, 2)
    return jnp.asarray(ret, jnp.float32), jnp.asarray(first)


def test_top_k_takes_one_heads_block_and_head_balanced_takes_every_head():
    ret, first = _layout()
    key = jax.random.PRNGKey(0)
    top = sel.select("top_k", ret, first, key, K * M, 3)
    np.testing.assert_allclose(top, first[2, jnp.argsort(-ret[2])[:3]].mean(0))  # all three from head 2
    bal = sel.select("head_balanced", ret, first, key, K * M, 3)
    best = [first[h, jnp.argmax(ret[h])] for h in range(K)]
    np.testing.assert_allclose(bal, np.mean(best, 0))


def test_head_centred_returns_remove_each_heads_offset():
    ret, _ = _layout()
    real = sel.real_mask(K, M, K * M - 1)  # the last cell (head 2, column 3) is padding
    c = sel.head_centred(jnp.where(real, ret, -jnp.inf), real)
    assert np.isneginf(c[2, 3])
    for h in range(K):
        np.testing.assert_allclose(np.mean(np.asarray(c[h])[np.asarray(real[h])]), 0.0, atol=1e-6)
    assert np.asarray(c).max() < 1.0  # head 2's +5 is gone


@pytest.fixture(scope="module")
def trained():
    obs, act, nxt = expert_data()
    agent = POIR(SMALL, 2, 2)
    params, _ = agent.fit(jax.random.PRNGKey(0), obs, act, nxt)
    return agent, params, obs


def _with(agent, **planner):
    return POIR(dataclasses.replace(agent.config, planner=dataclasses.replace(agent.config.planner, **planner)), 2, 2)


def test_all_models_score_is_the_mean_minus_lambda_std_over_every_world_model(trained):
    agent, params, obs = trained
    key = jax.random.PRNGKey(1)
    imag = agent.imagine(params, obs[3], key)  # the candidates' actions, own-model scoring
    for lam in (0.0, 1.0):
        a = _with(agent, scoring="all_models", scoring_lambda=lam)
        ret, first = a.rollouts(params, obs[3], key)
        np.testing.assert_array_equal(first, imag.actions[0])  # the same candidates, scored otherwise
        per_model = []
        for w in range(agent.config.ensemble_size):  # model w alone, open loop on the same actions
            wm_w = jax.tree_util.tree_map(lambda x: x[w], params.wm)
            s, total = imag.states[0], 0.0
            for t in range(agent.config.planner.horizon):
                s = s + agent.wm_module.apply(wm_w, jnp.concatenate([s, imag.actions[t]], -1))
                total = total + agent.trajectory_rewards(params, s, imag.actions[t])
            per_model.append(total)
        per_model = np.stack(per_model)
        want = per_model.mean(0) - lam * per_model.std(0)
        real = np.isfinite(np.asarray(ret))
        np.testing.assert_allclose(np.asarray(ret)[real], want[real], rtol=1e-4, atol=1e-4)
    assert not np.allclose(np.asarray(ret)[real], np.asarray(imag.returns)[real])


def test_gripper_flip_proposes_full_commands_reversed_at_the_given_rate(trained):
    agent, params, obs = trained
    key = jax.random.PRNGKey(2)
    for p, lo, hi in ((0.0, 0.0, 0.0), (0.3, 0.2, 0.4)):
        a = _with(agent, gripper_noise="flip", gripper_flip_prob=p)
        imag = a.imagine(params, obs[3], key)
        env = np.asarray(params.act_norm.inverse(imag.actions[0]))[..., -1]
        np.testing.assert_allclose(np.abs(env), 1.0, atol=1e-5)  # a full open or close command
        prior = np.asarray(params.act_norm.inverse(a._bc_each(params, imag.states[0])))[..., -1]
        flipped = np.mean(np.sign(env) != np.where(prior >= 0, 1.0, -1.0))
        assert lo <= flipped <= hi
    gauss = agent.imagine(params, obs[3], key)
    assert not np.allclose(np.abs(np.asarray(params.act_norm.inverse(gauss.actions[0]))[..., -1]), 1.0)


def test_dril_in_action_units_measures_the_heads_in_robosuites_units(trained):
    agent, params, obs = trained
    a = _with(agent, dril_units="action", reward="dril")
    s = agent.normalize_obs(params, obs[:5])
    heads = np.asarray(params.act_norm.inverse(agent._bc_all(params, s)))  # [K, 5, da] in env units
    want = -np.max(np.linalg.norm(heads[:, None] - heads[None], axis=-1), axis=(0, 1))
    np.testing.assert_allclose(a._dril(params, s), want, rtol=1e-5)
    assert not np.allclose(agent._dril(params, s), want)  # the normalised default measures another distance


def test_a_runs_selection_option_reaches_the_ranked_methods_and_not_the_random_control():
    from poir_mjx.core.config import apply_overrides, preset
    from poir_mjx.eval.methods import get_method

    base = apply_overrides(preset("cpu-small"), {"planner.selection": "head_balanced", "planner.scoring": "head_centred"})
    assert get_method("POIR-DRIL").agent_config(base).planner.selection == "head_balanced"
    assert get_method("POIR-L2").agent_config(base).planner.scoring == "head_centred"
    assert get_method("POIR-random").agent_config(base).planner.selection == "random"
    assert get_method("POIR-DRIL").agent_config(preset("cpu-small")).planner.selection == "top_k"


def test_l2_over_chosen_dimensions_ignores_the_others(trained):
    from poir_mjx.core.config import ConfigError

    agent, params, obs = trained
    a = _with(agent, reward="l2", l2_dims=(0,))
    s = agent.normalize_obs(params, obs[:6]) + jnp.array([0.0, 30.0])  # far off in the second dimension only
    e = np.asarray(params.expert_states)
    want = -np.min(np.abs(np.asarray(s)[:, None, 0] - e[None, :, 0]), axis=1)
    np.testing.assert_allclose(a.trajectory_rewards(params, s, None), want, rtol=1e-5, atol=1e-6)
    assert np.all(np.asarray(_with(agent, reward="l2").trajectory_rewards(params, s, None)) < want - 1.0)
    with pytest.raises(ConfigError, match="planner.l2_dims: 2 is not a dimension of the 2-wide observation"):
        _with(agent, l2_dims=(0, 2))
