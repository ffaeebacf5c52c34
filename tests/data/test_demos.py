"""The scripted expert and `make demos` on a tiny case: real robosuite physics, real file."""

import h5py
import json

import numpy as np
import pytest

from poir_mjx.data.demos import generate
from poir_mjx.data.robomimic import read_transitions
from poir_mjx.data.expert_episodes import robosuite_episode


@pytest.mark.needs_robosuite
def test_expert_lifts_the_cube_in_robosuite():
    results = [robosuite_episode("lift", seed) for seed in range(3)]
    assert all(ok for _, ok, _, _ in results)
    demo = results[0][0]
    assert demo.actions.shape[1] == 7 and np.all(np.abs(demo.actions) <= 1.0)
    assert demo.obs["object"].shape == (demo.actions.shape[0], 10)


@pytest.mark.needs_robosuite
def test_generate_writes_a_valid_robomimic_file_and_skips_done_work(tmp_path, capsys):
    path = generate("lift", num=2, seed=0, sigma_init=0.02, out=tmp_path, progress=False)
    tr = read_transitions(path, task="lift")
    assert len(tr.demo_names) == 2 and tr.obs.shape[1] == 19
    # s' of step t is s of step t+1 inside a demo
    np.testing.assert_allclose(tr.next_obs[:-1][: tr.demo_lengths[0] - 1], tr.obs[1 : tr.demo_lengths[0]], atol=1e-6)
    with h5py.File(path) as f:
        gen = json.loads(f["data"].attrs["poir_mjx_generator"])
        assert gen["simulator"].startswith("robosuite") and gen["expert"].startswith("poir-mjx scripted expert")
        assert f["data/demo_0/states"].shape[0] == f["data/demo_0/actions"].shape[0]
        assert "mujoco" in f["data/demo_0"].attrs["model_file"]
    mtime = path.stat().st_mtime_ns
    generate("lift", num=2, seed=0, sigma_init=0.02, out=tmp_path, progress=False)
    assert path.stat().st_mtime_ns == mtime and "skipped" in capsys.readouterr().out


@pytest.mark.needs_robosuite
def test_human_like_demos_are_their_own_file_naming_their_style(tmp_path):
    """`demos generate --demo-style human_like` in robosuite: successful demos only, in <task>-human[-n<num>].hdf5,
    the generator record naming the style, rotation actions that vary where the scripted ones hardly do."""
    from poir_mjx import cli
    from poir_mjx.data.spread import file_spread

    assert cli.main(["demos", "generate", "--tasks", "lift", "--num", "3", "--out", str(tmp_path),
                     "--demo-style", "human_like"]) == 0  # fmt: skip
    path = tmp_path / "lift-human-n3.hdf5"
    with h5py.File(path) as f:
        gen = json.loads(f["data"].attrs["poir_mjx_generator"])
        stats = json.loads(f["data"].attrs["poir_mjx_stats"])
        assert gen["demo_style"] == "human_like" and gen["simulator"].startswith("robosuite")
        assert all(f[f"data/demo_{k}/rewards"][-1] == 1 for k in range(3))  # each demo ends in success
    assert stats["success_rate"] == 3 / stats["episodes_tried"]
    spread = file_spread(path)
    assert spread["style"] == "human_like" and spread["std"]["rx"] > 0.01 and spread["std"]["ry"] > 0.01
