"""Typed configs (poir_mjx/core/config.py): presets, plain-data round trips, one error naming each bad field."""

import dataclasses

import pytest

from poir_mjx.core.config import (PRESETS, ConfigError, OnlineConfig, POIRConfig, apply_overrides, from_dict,
                                  offline_config, preset, to_dict)  # fmt: skip


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_presets_validate_and_round_trip_through_plain_data(name):
    cfg = preset(name)
    assert cfg.validate() is cfg
    assert from_dict(to_dict(cfg)) == cfg
    assert from_dict(to_dict(cfg)) is not cfg


def test_preset_values():
    paper = preset("paper")
    planner = paper.planner
    assert (planner.num_trajectories, planner.horizon, planner.sigma, paper.ensemble_size) == (4000, 5, 0.2, 27)
    assert (paper.bc.layers, paper.bc.width, paper.train.learning_rate, paper.train.batch_size) == (5, 300, 1e-4, 256)
    assert paper.online.total_env_steps == 500_000 and paper.online.eval_every == 50_000
    small = preset("cpu-small")
    assert (small.ensemble_size, small.bc.width, small.planner.num_trajectories) == (5, 64, 256)
    with pytest.raises(ConfigError, match="preset: unknown preset 'huge'"):
        preset("huge")


@pytest.mark.parametrize("data, match", [
    ({"planner": {"reward": "gail"}}, r"config: planner\.reward: 'gail' is not one of"),
    ({"planner": {"horizon": "5"}}, r"planner\.horizon: expected an integer, got '5'"),
    ({"planner": {"horizon": True}}, r"planner\.horizon: expected an integer, got True"),
    ({"planner": {"top_k": 20, "num_trajectories": 10}}, r"planner\.top_k: 20 exceeds num_trajectories 10"),
    ({"train": {"learning_rate": -1.0}}, r"train\.learning_rate: must be >= 0"),
    ({"train": {"learning_rate": float("nan")}}, r"train\.learning_rate: must be finite"),
    ({"bc": {"layers": 0}}, r"bc\.layers: must be positive, got 0"),
    ({"world_model": {"activation": "swish"}}, r"world_model\.activation: 'swish' is not one of"),
    ({"normalize": "yes"}, r"config: normalize: expected a boolean"),
    ({"action_low": 1.0}, r"action_low: must be below action_high"),
    ({"online": {"mix_max": 1.5}}, r"online\.mix_max: a fraction must be in \[0, 1\]"),
    ({"online": {"num_envs": 0}}, r"online\.num_envs: must be positive"),
    ({"online": {"updates_per_env_step": 0.0}}, r"online\.updates_per_env_step: must be > 0"),
    ({"planer": {}}, r"config: unknown field\(s\) \['planer'\] for POIRConfig"),
    ({"planner": {"horizn": 3}}, r"config\.planner: unknown field\(s\) \['horizn'\] for PlannerConfig"),
    ({"planner": 3}, r"config\.planner: expected a mapping for PlannerConfig, got int"),
])  # fmt: skip
def test_each_bad_value_is_one_error_naming_the_field(data, match):
    with pytest.raises(ConfigError, match=match) as e:
        from_dict(data)
    assert "\n" not in str(e.value)


def test_zero_is_allowed_where_it_means_off():
    cfg = from_dict({"planner": {"l2_approx_size": 0}, "normalizer": {"clip": 0.0, "position_std_floor": 0.0}})
    assert cfg.planner.l2_approx_size == 0 and cfg.normalizer.clip == 0.0


def test_dotted_overrides_and_the_offline_part():
    cfg = apply_overrides(preset("cpu-small"), {"online.total_env_steps": 1234, "planner.sigma": 0.1})
    assert cfg.online.total_env_steps == 1234 and cfg.planner.sigma == 0.1 and cfg.bc == preset("cpu-small").bc
    for dotted in ("online.nope", "planner", "nope.sigma"):
        with pytest.raises(ConfigError, match=rf"sweep\.json: '{dotted}' is not a config field"):
            apply_overrides(cfg, {dotted: 1}, source="sweep.json")
    with pytest.raises(ConfigError, match=r"planner\.sigma: must be >= 0"):
        apply_overrides(cfg, {"planner.sigma": -0.1})
    off = offline_config(cfg)
    assert off.online == OnlineConfig() and off.planner.sigma == 0.1
    assert dataclasses.replace(off, online=cfg.online) == cfg
    assert POIRConfig().online == OnlineConfig()
