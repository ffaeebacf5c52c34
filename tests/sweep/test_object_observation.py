"""`observation: "object"` (the paper's: robosuite's object-state vector alone) from the demos to the checkpoints, the
cells and the commands that load a run's agent; "low_dim" (the default) keys everything as before."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from poir_mjx import cli
from poir_mjx.core import checkpoint
from poir_mjx.data.robomimic import Demo, write_robomimic
from poir_mjx.envs.tasks import ROBOSUITE_ENV
from poir_mjx.eval.methods import get_method
from poir_mjx.sweep.artifacts import cell_hash, checkpoint_file, demos_for, train_or_load
from poir_mjx.sweep.config import SweepConfig, load_sweep_config
from tests.helpers import one_line_error

TINY = {"train.epochs": 1, "train.batch_size": 16, "ensemble_size": 2, "bc.width": 16, "world_model.width": 16}
OBJECT_SIZE = {"lift": 10, "pick_place_can": 14, "nut_assembly_square": 14}
PROV = {"source": "file", "path": "d.hdf5", "sha256": "0123456789abcdef"}


def demo_file(path: Path, task: str) -> Path:
    """Two random demos in robomimic's layout with `task`'s observation sizes (tests/helpers.make_demo's, any task)."""
    sizes = {"robot0_eef_pos": 3, "robot0_eef_quat": 4, "robot0_gripper_qpos": 2, "object": OBJECT_SIZE[task]}
    demos = []
    for seed, t in ((0, 30), (1, 25)):
        rng = np.random.default_rng(seed)
        demos.append(Demo(obs={k: rng.normal(size=(t, d)) for k, d in sizes.items()},
                          next_obs={k: rng.normal(size=(t, d)) for k, d in sizes.items()},
                          actions=rng.uniform(-1, 1, (t, 7)), rewards=np.zeros(t), dones=np.r_[np.zeros(t - 1), 1],
                          states=rng.normal(size=(t, 33)), model_file="<mujoco/>"))  # fmt: skip
    return write_robomimic(path, demos, {"env_name": ROBOSUITE_ENV[task], "type": 1, "env_kwargs": {}})


def test_default_observation_keys_checkpoints_and_cells_as_before():
    """The names and hashes main computed before the field existed (same config, same data digest); "object" gets
    its own checkpoints and cells."""
    cfg = SweepConfig(name="t", tasks=("lift", "pick_place_can"), methods=("EBC", "POIR-DRIL"), ranking="paper")
    before = {("lift", "EBC"): ("policy-seed0-0b019943958395d6.ckpt", "ca16774e1f00a4f5"),
              ("lift", "POIR-DRIL"): ("poir-seed0-e9ca16a0e4bb9de7.ckpt", "cae92ce9ebf58f50"),
              ("pick_place_can", "EBC"): ("policy-seed0-effeed129abb47a3.ckpt", "ca16774e1f00a4f5"),
              ("pick_place_can", "POIR-DRIL"): ("poir-seed0-a472881079c89f13.ckpt", "cae92ce9ebf58f50")}  # fmt: skip
    obj = dataclasses.replace(cfg, observation="object")
    for (task, method), (ckpt, chash) in before.items():
        path, _, layout = checkpoint_file(get_method(method), cfg, task, 0, PROV, Path("ck"))
        assert (path.name, cell_hash(cfg, task, method, PROV["sha256"])) == (ckpt, chash)
        assert layout["obs_keys"] == ["robot0_eef_pos", "robot0_eef_quat", "robot0_gripper_qpos", "object"]
        path2, _, layout2 = checkpoint_file(get_method(method), obj, task, 0, PROV, Path("ck"))
        assert path2.name != ckpt and cell_hash(obj, task, method, PROV["sha256"]) != chash
        assert layout2["obs_keys"] == ["object"]


@pytest.mark.parametrize("task", ["lift", "pick_place_can"])
def test_object_observation_trains_agents_on_the_object_state_alone(task, tmp_path):
    path = demo_file(tmp_path / f"{task}.hdf5", task)
    cfg = SweepConfig(name="t", tasks=(task,), methods=("EBC",), demo_files={task: str(path)}, overrides=TINY,
                      observation="object")  # fmt: skip
    tr, prov = demos_for(cfg, task, tmp_path / "data", progress=False)
    assert tr.obs.shape[1] == tr.next_obs.shape[1] == OBJECT_SIZE[task] and tr.obs_keys == ("object",)
    low, _ = demos_for(SweepConfig(name="t", tasks=(task,), demo_files={task: str(path)}), task, tmp_path, False)
    np.testing.assert_array_equal(low.obs[:, 9:], tr.obs)  # the object-state columns of the low-dim vector
    agent, _, ckpt = train_or_load(get_method("EBC"), cfg, task, 0, tr, prov, tmp_path / "ckpt", progress=False)
    assert agent.obs_size == OBJECT_SIZE[task]
    _, _, layout = checkpoint.load(ckpt)
    assert layout["obs_keys"] == ["object"] and layout["obs_size"] == OBJECT_SIZE[task]


def test_a_checkpoint_of_another_observation_is_refused_in_one_line(tmp_path, capsys):
    path = demo_file(tmp_path / "lift.hdf5", "lift")
    cfg = SweepConfig(name="t", methods=("EBC",), demo_files={"lift": str(path)}, overrides=TINY, observation="object")
    tr, prov = demos_for(cfg, "lift", tmp_path / "data", progress=False)
    agent, params, ckpt = train_or_load(get_method("EBC"), cfg, "lift", 0, tr, prov, tmp_path / "ckpt", False)
    low = SweepConfig(name="t", methods=("EBC",), demo_files={"lift": str(path)}, overrides=TINY)
    _, tcfg, layout = checkpoint_file(get_method("EBC"), low, "lift", 0, prov, tmp_path / "ckpt")
    with pytest.raises(checkpoint.CheckpointError, match="layout field 'obs_keys' is \\['object'\\]") as e:
        checkpoint.load(ckpt, tcfg, layout)  # the low-dim run's layout against the object-state agent
    assert "\n" not in str(e.value)
    # eval builds the observation the checkpoint names; one it cannot build, or a size that disagrees, is refused
    for name, keys in (("unknown", ["robot0_eef_pos"]), ("wrong-size", list(layout["obs_keys"]))):
        bad = checkpoint.save(tmp_path / f"{name}.ckpt", agent, params, {"task": "lift", "obs_keys": keys})
        assert cli.main(["eval", "--ckpt", str(bad), "--episodes", "1", "--max-steps", "1"]) == 2
        err = one_line_error(capsys)
        assert ("is not an observation this version can build" if name == "unknown" else
                "'obs_size' does not match task lift's low_dim observation") in err, err


def test_diagnose_refuses_a_run_on_the_object_observation(tmp_path):
    from poir_mjx.core.config import ConfigError
    from poir_mjx.diagnose.config import DiagnoseConfig
    from poir_mjx.diagnose.run import run

    (tmp_path / "r").mkdir()
    (tmp_path / "r" / "config.json").write_text(json.dumps({"name": "r", "methods": ["POIR-DRIL"],
                                                            "observation": "object"}))  # fmt: skip
    with pytest.raises(ConfigError, match="field 'observation' is 'object'; diagnose takes runs on the low_dim"):
        run(DiagnoseConfig(run=tmp_path / "r", out=tmp_path / "diag", progress=False))


@pytest.mark.needs_robosuite
def test_tiny_sweep_on_the_object_observation_in_robosuite(tmp_path, capsys):
    """Random demos, EBC trained on 10 inputs, its cells evaluated in robosuite (whose workers must send 10 numbers:
    the compiled policy takes no other width); the run records its observation, so its agent loads again and `eval`
    of its checkpoint observes the same way."""
    from poir_mjx.sweep import run as sw
    from poir_mjx.sweep.artifacts import load_run_agent

    demos = demo_file(tmp_path / "lift.hdf5", "lift")
    raw = {"name": "tiny-obj", "tasks": ["lift"], "methods": ["EBC"], "sigma_init": [0.02], "seeds": [0],
           "episodes": 1, "max_steps": 3, "overrides": TINY, "demo_files": {"lift": str(demos)},
           "simulator": "robosuite", "workers": 1, "observation": "object"}  # fmt: skip
    (tmp_path / "tiny.json").write_text(json.dumps(raw))
    cfg = load_sweep_config(tmp_path / "tiny.json")
    out = sw.run_sweep(cfg, tmp_path / "results", tmp_path / "data", tmp_path / "ckpt", progress=False)
    rec = json.loads((out / "cells/lift/EBC/si=0.02_sa=0_seed=0.json").read_text())
    assert rec["episodes"] == 1 and rec["successes"] == 0 and rec["mean_episode_length"] == 3
    assert "outcomes" not in rec  # the object-state has no hand position to say how an episode ended
    assert rec["config_hash"] == cell_hash(cfg, "lift", "EBC", rec["data"]["sha256"])
    assert json.loads((out / "config.json").read_text())["observation"] == "object"
    assert "Observation: object (robosuite's object-state vector alone)." in (out / "lift.md").read_text()
    agent, _, _ = load_run_agent(out, "lift", "EBC", 0, ckpt_dir=tmp_path / "ckpt", progress=False)
    assert agent.obs_size == 10
    ckpt = next((tmp_path / "ckpt" / "lift").glob("policy-seed0-*.ckpt"))
    rc = cli.main(["eval", "--ckpt", str(ckpt), "--simulator", "robosuite", "--episodes", "1", "--max-steps", "2",
                   "--workers", "1"])  # fmt: skip
    assert rc == 0 and "| 0.02 | 0 | 0.00 [" in capsys.readouterr().out


@pytest.mark.slow
def test_tiny_sweep_on_the_object_observation_in_mjx(tmp_path):
    """The same in MJX: the compiled evaluator observes through the object-observation environment (an agent of 10
    inputs fed the 19-number low-dim vector would not compile). Compiles a Lift rollout: 3.7 min on the shared 2-core
    CPU."""
    from poir_mjx.sweep import run as sw

    demos = demo_file(tmp_path / "lift.hdf5", "lift")
    cfg = SweepConfig(name="tiny-obj-mjx", methods=("EBC",), sigma_init=(0.02,), episodes=1, max_steps=2,
                      overrides=TINY, demo_files={"lift": str(demos)}, observation="object")  # fmt: skip
    out = sw.run_sweep(cfg, tmp_path / "results", tmp_path / "data", tmp_path / "ckpt", progress=False)
    rec = json.loads((out / "cells/lift/EBC/si=0.02_sa=0_seed=0.json").read_text())
    assert rec["episodes"] == 1 and rec["successes"] == 0 and rec["simulator"].startswith("MJX")
