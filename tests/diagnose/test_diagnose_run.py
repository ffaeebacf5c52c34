"""The whole forensics path on a tiny Lift run: the cell's episode in robosuite, the planner taken apart, the
oracle's rollouts from restored states, the records and the page; plus the restore it rests on."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from poir_mjx.core.config import ConfigError
from poir_mjx.data.robomimic import write_robomimic
from poir_mjx.diagnose.config import DiagnoseConfig, check
from poir_mjx.sweep import run_folder
from poir_mjx.sweep.config import SweepConfig
from tests.helpers import ENV_ARGS, make_demo

pytestmark = pytest.mark.needs_robosuite


def test_a_restored_robosuite_state_replays_bit_for_bit():
    """save/restore keep everything a step depends on: MuJoCo's state and warm start, robosuite's gripper ramp (without
    it the same actions from the same snapshot drifted by 1.5 cm)."""
    from poir_mjx.diagnose.simulate import Oracle, run_episode

    rng = np.random.default_rng(0)
    acts = rng.uniform(-0.5, 0.5, (24, 7))
    acts[:, 6] = np.sign(acts[:, 6])  # the gripper toggles: its ramp is state outside MuJoCo
    it = iter(acts)
    ep, snaps = run_episode("lift", 123, 0.1, lambda o, k: next(it), np.zeros((24, 2), np.uint32), 24, 8, 0)
    oracle = Oracle("lift", 123, 0.1)
    try:
        for snap in snaps[1:]:
            seq = np.stack([acts[snap.step : snap.step + 5]] * 2)
            out = oracle.rollout(snap, seq)
            np.testing.assert_array_equal(out[:, 0], ep.obs[snap.step : snap.step + 6])
            np.testing.assert_array_equal(out[:, 1], out[:, 0])
    finally:
        oracle.close()


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    """A sweep run folder whose POIR agent trains in seconds on 3 random demos (planner: K 2, N 8, H 2)."""
    root = tmp_path_factory.mktemp("run")
    demos = write_robomimic(root / "lift.hdf5", [make_demo(8, s) for s in range(3)], ENV_ARGS)
    cfg = SweepConfig(name="tiny", methods=("POIR-DRIL",), sigma_init=(0.02, 0.3), episodes=2, max_steps=4,
                      demo_files={"lift": str(demos)}, ranking="paper",  # "L2" below is then the planner's own
                      overrides={"train.epochs": 1, "train.batch_size": 8, "ensemble_size": 2,
                                 "planner.num_trajectories": 8, "planner.horizon": 2, "planner.top_k": 2})  # fmt: skip
    run_folder.prepare(root / "tiny", dataclasses.asdict(cfg))
    return root


def test_diagnose_writes_records_and_the_page_and_resumes(tiny_run, tmp_path, capsys):
    from poir_mjx.diagnose.run import run

    out = tmp_path / "diag"
    cfg = DiagnoseConfig(run=tiny_run / "tiny", sigma_init=(0.3,), episodes=(1,), every=2, steps=4, out=out, holdout=0.34,
                         checkpoints=tiny_run / "ckpt", progress=False)  # fmt: skip
    assert run(cfg) == 0
    path = out / "lift" / "POIR-DRIL" / "si=0.3_seed=0" / "episode=1.json"
    rec = json.loads(path.read_text())
    assert rec["simulator"] == "robosuite" and rec["steps"] <= 4 and [c["step"] for c in rec["calls"]][:2] == [0, 2]
    call = rec["calls"][0]
    for r in ("l2", "dril", "morel"):
        assert sum(call[r]["top_k_heads"]) == 2 and -1 <= call[r]["spearman"] <= 1 and 0 <= call[r]["top_k_overlap"] <= 1
        assert call[r]["true_gain_oracle_top_k"] >= call[r]["true_gain_model_top_k"] - 1e-6  # the oracle's top-k is best
    from poir_mjx.diagnose.rankings import RANKINGS

    assert set(call["rankings"]) == set(RANKINGS)  # every ranking option judged on the same candidates
    for t in ("l2", "dril"):
        assert call["rankings"]["L2" if t == "l2" else "DRIL"][t]["gain"] == pytest.approx(call[t]["true_gain_model_top_k"])
    assert len(call["shares"]["l2"]) == 19 and len(call["shares"]["dril"]) == 7
    assert sum(call["shares"]["dril"]) == pytest.approx(1.0)
    assert len(call["one_step_sq_error"]) == 19 and len(rec["demos"]["error"]) == 19
    assert len(rec["demos"]["holdout_held_out_error"]) == 19  # a world model trained on 2 of the 3 demos
    page = (out / "lift.md").read_text()
    assert "POIR-DRIL si=0.3_seed=0" in page and "Spearman" in page and "Every ranking option" in page and "eef_quat" in page and "held_out: cube_pos" in page
    assert rec["provenance"]["demos"]["source"] == "file" and "Simulator: robosuite" in page
    assert json.loads((out / "config.json").read_text())["diagnose"] == str(tiny_run / "tiny")  # committed: read-only
    assert (out / "lift-shares.png").stat().st_size > 1000
    before = path.stat().st_mtime_ns
    assert run(cfg) == 0  # the finished episode is reused, the page rewritten
    assert path.stat().st_mtime_ns == before


@pytest.mark.parametrize("field, value, match", [
    ("method", "EBC", "field 'method': 'EBC' is not an offline planner method"),
    ("sigma_init", (), "diagnose: sigma_init"), ("episodes", (1, 1), "diagnose: episodes"), ("every", 0, "diagnose: every"),
    ("seed", -1, "diagnose: seed"), ("task", "stack", "field 'task'"), ("holdout", 1.0, "diagnose: holdout")])  # fmt: skip
def test_bad_fields_name_the_field(field, value, match):
    with pytest.raises(ConfigError, match=match):
        check(dataclasses.replace(DiagnoseConfig(run=Path("results/x")), **{field: value}))
