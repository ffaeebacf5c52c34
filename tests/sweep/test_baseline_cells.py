"""A sweep's baseline cells (eval/cells.py run_baseline_cells) and their learning-curve report, on the point-mass toy
with a learner whose progress is known (the real learners are tested in tests/baselines)."""

import dataclasses
import json

import numpy as np
import pytest

from poir_mjx.baselines import registry
from poir_mjx.sweep import cells
from poir_mjx.sweep.artifacts import cell_hash, cell_path, read_cell
from poir_mjx.sweep.curves import write_baseline_curves
from poir_mjx.rollout.evaluator import episode_keys
from poir_mjx.sweep.plan import SweepPlan
from poir_mjx.sweep.config import SweepConfig
from tests.helpers import StepLearner
from tests.helpers import PointMassEnv


@dataclasses.dataclass(frozen=True)
class FakeConfig:
    total_env_steps: int = 24
    eval_every: int = 8

    def validate(self):
        return self


class FakeBaseline(registry.Baseline):
    def config(self, preset, overrides=None, source=""):
        return FakeConfig(**(overrides or {}))

    def make(self, env, cfg, obs_size, act_size):
        return StepLearner()


@dataclasses.dataclass
class Toy:
    obs = np.zeros((6, 2), np.float32)
    actions = np.zeros((6, 2), np.float32)
    next_obs = np.zeros((6, 2), np.float32)
    demo_starts = np.array([0, 3])
    demo_lengths = np.array([3, 3])


@pytest.fixture
def toy_sweep(monkeypatch, tmp_path):
    monkeypatch.setitem(registry.BASELINES, "DAC", FakeBaseline("DAC", "dac", "DAC", "fake"))
    monkeypatch.setattr(cells, "make_env", lambda task, **kw: PointMassEnv(drift_y=0.0, horizon=30))
    cfg = SweepConfig(name="toy", methods=("DAC",), sigma_init=(0.0, 0.05), episodes=8, max_steps=30)
    grid = [(si, 0.0) for si in cfg.sigma_init]
    chash = cell_hash(cfg, "lift", "DAC", "digest")
    paths = [cell_path(tmp_path, "lift", "DAC", si, sa, 0) for si, sa in grid]
    batch = cells.CellBatch(cfg, "lift", "DAC", 0, grid, paths, episode_keys(0, 16), chash, {"config_hash": chash})
    return cfg, batch, tmp_path


def test_each_noise_cell_trains_records_its_curve_and_is_not_redone(toy_sweep):
    cfg, batch, out = toy_sweep
    done = []
    cells.run_baseline_cells(batch, Toy(), out / "ckpt", False, done.append)
    assert done == [8, 8]
    for path in batch.paths:
        rec = read_cell(path, batch.chash)
        assert [c["env_steps"] for c in rec["curve"]] == [0, 8, 16, 24]
        assert rec["curve"][0]["successes"] == 0 and rec["successes"] == 8 == rec["curve"][-1]["successes"]
        assert rec["baseline"] == {"total_env_steps": 24, "eval_every": 8}
    assert len(list((out / "ckpt" / "lift" / "baselines").glob("DAC-si=*_seed=0-*.ckpt"))) == 2
    before = [p.stat().st_mtime_ns for p in batch.paths]
    cells.run_baseline_cells(batch, Toy(), out / "ckpt", False, done.append)
    assert [p.stat().st_mtime_ns for p in batch.paths] == before  # finished cells are read, not recomputed
    md = write_baseline_curves(SweepPlan.build(cfg, out, {"lift": "digest"}), "lift")
    assert "| DAC, σ_init 0 | 0: 0/8; 8: " in md and "24: 8/8" in md
    assert (out / "lift-baselines.png").stat().st_size > 0


def test_overrides_change_the_cell_hash(toy_sweep):
    cfg, _, _ = toy_sweep
    other = dataclasses.replace(cfg, baseline_overrides={"DAC": {"total_env_steps": 48}})
    assert cell_hash(cfg, "lift", "DAC", "d") != cell_hash(other, "lift", "DAC", "d")
    assert json.loads(json.dumps(dataclasses.asdict(other)))["baseline_overrides"] == {"DAC": {"total_env_steps": 48}}
