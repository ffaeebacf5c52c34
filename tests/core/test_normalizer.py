"""Std floors per observation group (issue: near-constant expert dimensions dominated the planner)."""

import dataclasses

import jax
import numpy as np
import pytest

from poir_mjx.core.agent import POIR
from poir_mjx.core.config import MLPConfig, NormalizerConfig, POIRConfig, TrainConfig
from poir_mjx.core.normalizer import Normalizer, observation_floor
from poir_mjx.envs.layout import obs_groups

PAPER = NormalizerConfig(position_std_floor=0.0, quaternion_std_floor=0.0, gripper_std_floor=0.0, action_std_floor=0.0)


def test_lift_layout_groups():
    g = obs_groups("lift")
    assert len(g) == 19
    assert g[:3] == ("position",) * 3 and g[3:7] == ("quaternion",) * 4 and g[7:9] == ("gripper",) * 2
    assert g[9:12] == ("position",) * 3 and g[12:16] == ("quaternion",) * 4 and g[16:] == ("position",) * 3


@pytest.mark.parametrize("task", ["pick_place_can", "nut_assembly_square"])
def test_can_and_square_layout_groups(task):
    g = obs_groups(task)
    assert len(g) == 23 and g[9:12] == ("position",) * 3 and g[12:16] == ("quaternion",) * 4
    assert g.count("quaternion") == 12


def _lift_like_data(n=2000, seed=0):
    """Lift-shaped expert observations: the cube's quaternion x/y barely move (std 0.0008, as in the demos)."""
    rng = np.random.default_rng(seed)
    obs = rng.normal(0.0, 0.05, (n, 19)).astype(np.float32)
    obs[:, 12:14] = rng.normal(0.0, 0.0008, (n, 2))
    return obs


def test_a_small_cube_tilt_is_about_one_std_not_sixty():
    obs = _lift_like_data()
    floor = observation_floor(NormalizerConfig(), obs_groups("lift"), 19)
    tilted = obs.mean(0).copy()
    tilted[12] += 0.05  # the cube's quaternion x: a tilt of about 6 degrees
    z_floored = np.asarray(Normalizer.fit(obs, True, floor)(tilted))[12]
    z_paper = np.asarray(Normalizer.fit(obs, True, observation_floor(PAPER, obs_groups("lift"), 19))(tilted))[12]
    assert abs(z_floored) <= 1.01
    assert abs(z_paper) > 50  # the paper's plain standardisation, still reachable


def test_floors_apply_only_where_the_data_is_narrower():
    obs = _lift_like_data()
    std = np.asarray(Normalizer.fit(obs, True, observation_floor(NormalizerConfig(), obs_groups("lift"), 19)).std)
    np.testing.assert_allclose(std[12:14], 0.05)
    np.testing.assert_allclose(std[:3], obs[:, :3].std(0), rtol=1e-5)  # 5 cm spread > the 1 cm floor
    np.testing.assert_allclose(std[7:9], obs[:, 7:9].std(0), rtol=1e-5)


def test_layout_mismatch_and_unknown_group_are_refused():
    with pytest.raises(ValueError, match="obs_groups: 19 entries"):
        observation_floor(NormalizerConfig(), obs_groups("lift"), 23)
    with pytest.raises(ValueError, match="unknown group"):
        observation_floor(NormalizerConfig(), ("position", "angle"), 2)


def test_agent_fit_shares_the_floored_normaliser_and_clips():
    obs = _lift_like_data(n=256)
    act = np.zeros((256, 7), np.float32)  # constant expert actions: the action floor keeps the bounds finite
    cfg = POIRConfig(ensemble_size=2, bc=MLPConfig(layers=2, width=8), world_model=MLPConfig(layers=2, width=8),
                     train=TrainConfig(epochs=1, batch_size=64),
                     normalizer=NormalizerConfig(action_std_floor=0.05))  # fmt: skip
    agent = POIR(cfg, 19, 7)
    params, _ = agent.fit(jax.random.PRNGKey(0), obs, act, obs, obs_groups=obs_groups("lift"))
    np.testing.assert_allclose(np.asarray(params.obs_norm.std)[12:14], 0.05)
    np.testing.assert_allclose(np.asarray(params.act_norm.std), 0.05)
    # the L2 reward searches the same normalised expert states the prior and the model were trained on
    np.testing.assert_allclose(np.asarray(params.expert_states), np.asarray(params.obs_norm(obs)), atol=1e-6)
    far = obs.mean(0) + 10.0
    clipped = POIR(dataclasses.replace(cfg, normalizer=dataclasses.replace(cfg.normalizer, clip=5.0)), 19, 7)
    assert float(np.abs(np.asarray(clipped.normalize_obs(params, far))).max()) == 5.0
    assert float(np.abs(np.asarray(agent.normalize_obs(params, far))).max()) > 100.0
