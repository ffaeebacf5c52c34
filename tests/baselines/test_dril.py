"""DRIL's reward from a BC ensemble trained on the toy expert (tests/baselines/toy_ppo.py)."""

import dataclasses

import jax
import numpy as np
import pytest

from poir_mjx.baselines import dril
from poir_mjx.baselines.ppo_dril import PRESETS
from poir_mjx.core import ensemble
from tests.baselines.toy_ppo import expert_data

CFG = PRESETS["cpu-small"].dril  # 5 networks of 3x64, 50 epochs


@pytest.fixture(scope="module")
def fitted():
    ex = expert_data()
    return ex, dril.fit(CFG, jax.random.PRNGKey(0), ex.obs, ex.actions, ex.next_obs)


def members(rew, obs):
    """Each member's (standardised) action at raw observations, numpy [K, B, da]."""
    return np.asarray(ensemble.apply_all(dril.module(CFG, 2), rew.params, rew.obs_norm(obs)))


def reward(cfg, rew, obs, act, nxt):
    return np.asarray(dril.reward(cfg, dril.module(cfg, 2), rew, obs, act, nxt))


def test_max_pairwise_disagreement_is_the_projects_and_the_threshold_its_expert_quantile(fitted):
    ex, rew = fitted
    preds = members(rew, ex.next_obs)
    manual = np.sqrt(((preds[:, None] - preds[None, :]) ** 2).sum(-1)).max(axis=(0, 1))
    d = np.asarray(dril.disagreement(CFG, dril.module(CFG, 2), rew, ex.obs, ex.actions, ex.next_obs))
    np.testing.assert_allclose(d, manual, rtol=1e-4, atol=1e-6)
    assert float(rew.threshold) == pytest.approx(np.quantile(manual, CFG.quantile), rel=1e-4)
    r = reward(CFG, rew, ex.obs, ex.actions, ex.next_obs)
    assert set(np.unique(r)) <= {-1.0, 1.0}
    assert np.mean(r == 1.0) == pytest.approx(CFG.quantile, abs=0.01)


def test_states_off_the_expert_band_are_penalised(fitted):
    ex, rew = fitted
    t = np.linspace(0.0, 1.0, 31, dtype=np.float32)
    on = np.stack([0.05 * 30 * t, np.zeros_like(t), t], -1)  # the expert's path
    off = on + np.array([0.0, 0.3, 0.0], np.float32)  # 0.3 above it (the expert's |y| < ~0.04)
    act = np.zeros((31, 2), np.float32)
    assert np.mean(reward(CFG, rew, on, act, on) == 1.0) >= 0.9
    assert np.all(reward(CFG, rew, off, act, off) == -1.0)
    raw = dataclasses.replace(CFG, clip="none")
    r_on, r_off = reward(raw, rew, on, act, on), reward(raw, rew, off, act, off)
    assert np.all((r_on <= 0) & (r_on >= -dril.RAW_FLOOR) & (r_off >= -dril.RAW_FLOOR))
    assert r_off.mean() < r_on.mean() - 1.0  # in threshold units: well past the expert quantile
    bad = off.copy()
    bad[0, 1] = np.nan  # a diverged state counts as the worst
    assert reward(CFG, rew, on, act, bad)[0] == -1.0 and reward(raw, rew, on, act, bad)[0] == -dril.RAW_FLOOR


def test_action_variance_is_drils_continuous_form(fitted):
    ex, rew = fitted
    cfg = dataclasses.replace(CFG, disagreement="action_variance")
    rew_av = dril.with_threshold(cfg, rew, ex.obs, ex.actions, ex.next_obs)
    preds = members(rew, ex.obs[:64])  # [K, B, da]
    a = np.asarray(rew.act_norm(ex.actions[:64]))
    manual = np.array([a[i] @ np.cov(preds[:, i].T) @ a[i] for i in range(64)])
    d = np.asarray(dril.disagreement(cfg, dril.module(cfg, 2), rew_av, ex.obs[:64], ex.actions[:64], ex.next_obs[:64]))
    np.testing.assert_allclose(d, manual, rtol=1e-3, atol=1e-7)
    r = reward(cfg, rew_av, ex.obs, ex.actions, ex.next_obs)
    assert np.mean(r == 1.0) == pytest.approx(cfg.quantile, abs=0.01)


def test_quantile_out_of_range_names_the_field():
    ex = expert_data(n_demos=2)
    with pytest.raises(ValueError, match="^quantile"):
        dril.fit(dataclasses.replace(CFG, quantile=0.0), jax.random.PRNGKey(0), ex.obs, ex.actions, ex.next_obs)
