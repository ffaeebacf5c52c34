"""The registry builds every baseline from its presets and a sweep's overrides (no training here)."""

import pytest

from poir_mjx.baselines.registry import BASELINES, get_baseline
from poir_mjx.core.config import ConfigError
from poir_mjx.eval.methods import get_method
from poir_mjx.sweep.config import load_sweep_config
from tests.helpers import PointMassEnv


@pytest.mark.parametrize("name", list(BASELINES))
def test_each_baseline_builds_from_its_presets(name):
    b = get_baseline(name)
    assert get_method(name).is_baseline and get_method(name).has_curve
    for preset in ("paper", "cpu-small"):
        total, every = b.schedule(b.config(preset))
        assert 0 < every <= total
    learner = b.make(PointMassEnv(), b.config("cpu-small"), 2, 2)
    assert learner.env_steps_per_iteration > 0


def test_overrides_reach_the_config_and_bad_ones_name_the_field():
    sweep = load_sweep_config("experiments/cpu-baselines.json")
    for name, overrides in sweep.baseline_overrides.items():
        total, every = get_baseline(name).schedule(get_baseline(name).config("cpu-small", overrides))
        assert (total, every) == (4096, 2048)
    with pytest.raises(ConfigError, match=r"baseline_overrides.SQIL: 'loop.nonsense' is not a config field"):
        get_baseline("SQIL").config("cpu-small", {"loop.nonsense": 1})
    with pytest.raises(ConfigError, match="baseline_overrides.DAC"):
        get_baseline("DAC").config("cpu-small", {"loop.num_envs": 0})
