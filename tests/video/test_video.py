"""Episode videos: frames that show the arm, written to an MP4 and read back; the cell's episode keys;
a run's agent loaded publicly; a missing OpenGL library is one line and exit status 2."""

import copy
import ctypes.util
import dataclasses
import os
import subprocess
import sys
from pathlib import Path

import jax
import numpy as np
import pytest

from poir_mjx.core.config import ConfigError
from poir_mjx.data.robomimic import write_robomimic
from poir_mjx.sweep import run_folder
from poir_mjx.sweep.artifacts import load_run_agent
from poir_mjx.rollout.evaluator import episode_keys
from poir_mjx.sweep.config import SweepConfig, load_sweep_config
from poir_mjx.video import VideoConfig, render_video
from poir_mjx.video.config import check
from poir_mjx.video.encode import read_mp4, write_mp4
from poir_mjx.video.record import Recording
from poir_mjx.video.render import Painter, renderer
from poir_mjx.video.scene import arm_geoms, scene_model
from poir_mjx.video.video import cell_episodes, frames
from tests.helpers import ENV_ARGS, make_demo

ROOT = Path(__file__).resolve().parents[2]
W, H = 96, 72


def arm_poses(model, n=3):
    """n qpos vectors of Lift: the exported initial pose with the shoulder and elbow swung further each time."""
    import mujoco

    q = model.qpos0.copy()
    for k, name in enumerate(f"robot0_joint{i}" for i in range(1, 8)):
        q[model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)]] = (
            [0.0, 0.2, 0.0, -2.6, 0.0, 2.9, 0.8][k])  # fmt: skip
    out = []
    for i in range(n):
        qi = q.copy()
        qi[model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "robot0_joint1")]] = 0.3 * i
        out.append(qi)
    return np.stack(out)


def test_mp4_frames_show_the_arm(tmp_path):
    model = scene_model("lift", 3)
    poses = arm_poses(model)
    with renderer(model, W, H) as r:
        painter = Painter(r, model, "three_quarter")
        shown = [painter.frame(q) for q in poses]
        seg = painter.segmentation(poses[0])
    hidden_model = copy.copy(model)
    hidden_model.geom_rgba[arm_geoms(model), 3] = 0.0  # the same scene without the drawn arm
    with renderer(hidden_model, W, H) as r:
        no_arm = Painter(r, hidden_model, "three_quarter").frame(poses[0])

    path = write_mp4(tmp_path / "arm.mp4", shown, fps=20)
    video = read_mp4(path)
    assert video.shape == (3, H, W, 3) and not list(tmp_path.glob(".*.tmp"))
    arm = np.isin(seg, arm_geoms(model))
    assert 0.02 < arm.mean() < 0.6, f"the arm covers {arm.mean():.3f} of the frame"
    diff = np.abs(video[0].astype(int) - no_arm.astype(int)).mean(-1)
    # Where the segmentation sees the arm, the decoded frame differs from the arm-less scene; elsewhere
    # (away from the arm's edges, which H.264 blurs) it is the same picture.
    from scipy.ndimage import binary_dilation

    assert diff[arm].mean() > 40, diff[arm].mean()
    assert diff[~binary_dilation(arm, iterations=2)].mean() < 6
    assert np.abs(video[2].astype(int) - video[0]).mean() > 1  # the arm moved between frames


def test_side_by_side_frames_are_captioned_tiles():
    model = scene_model("lift", 5)
    q = arm_poses(model, 2)[None]  # [B=1, T=2, nq]
    rec = lambda first: Recording(qpos=q, success=np.zeros((1, 2), bool), variant=np.array([5]),  # noqa: E731
                                  first_success=np.array([first]), diverged=np.zeros(1, bool))  # fmt: skip
    out = list(frames("lift", ["EBC", "POIR-DRIL"], [rec(-1), rec(1)], (4,), 0.4, W, H, "three_quarter"))
    assert len(out) == 2 and out[0].shape == (H, 2 * W, 3) and out[0].dtype == np.uint8
    left, right = out[1][:, :W], out[1][:, W:]
    band = H // 22 + 4
    assert left[:band].mean() < 60  # the caption's dark band (white text on it)
    np.testing.assert_array_equal(left[H // 2 :], right[H // 2 :])  # same state, same picture below the captions
    assert not np.array_equal(left[:band], right[:band])  # different names; "success at step 1" on the right


def test_cell_episodes_are_the_sweeps_keys_and_noise(tmp_path):
    run = SweepConfig(name="r", sigma_init=(0.02, 0.3), sigma_action=(0.0, 0.1), episodes=3, seeds=(0, 1))
    cfg = VideoConfig(run=tmp_path, sigma_init=0.3, sigma_action=0.0, episodes=(2, 0), seed=1)
    keys, params = cell_episodes(run, tmp_path / "config.json", cfg)
    # the sweep: grid (0.02, 0), (0.02, 0.1), (0.3, 0), (0.3, 0.1), 3 episodes each, one key per episode
    sweep_keys = episode_keys(1, 12)
    np.testing.assert_array_equal(keys, sweep_keys[np.array([8, 6])])
    np.testing.assert_allclose(params.sigma_init, [0.3, 0.3])
    np.testing.assert_allclose(params.sigma_action, [0.0, 0.0])
    with pytest.raises(ConfigError, match=r"config.json: the run has no cell sigma_init 0.2"):
        cell_episodes(run, tmp_path / "config.json", dataclasses.replace(cfg, sigma_init=0.2))
    with pytest.raises(ConfigError, match=r"video: field 'episodes': 3 is not an episode of the cell"):
        cell_episodes(run, tmp_path / "config.json", dataclasses.replace(cfg, episodes=(3,)))


@pytest.mark.parametrize(
    "field, value, match",
    [("width", 97, "field 'width' must be an even"), ("versus", "POIR", "field 'versus': unknown method"),
     ("episodes", (), "field 'episodes'"), ("sigma_init", -0.1, "field 'sigma_init'"),
     ("out", Path("v.gif"), "field 'out'")],
)  # fmt: skip
def test_bad_fields_name_the_field(field, value, match):
    with pytest.raises(ConfigError, match=match):
        check(dataclasses.replace(VideoConfig(run=Path("results/x")), **{field: value}))


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    """A sweep run folder (no cell evaluated yet) whose EBC agent trains in seconds on 3 random demos."""
    root = tmp_path_factory.mktemp("run")
    demos = write_robomimic(root / "lift.hdf5", [make_demo(8, s) for s in range(3)], ENV_ARGS)
    cfg = SweepConfig(name="tiny", methods=("EBC",), sigma_init=(0.02, 0.3), episodes=2, max_steps=3,
                      demo_files={"lift": str(demos)},
                      overrides={"train.epochs": 1, "train.batch_size": 8, "ensemble_size": 2})  # fmt: skip
    run_folder.prepare(root / "tiny", dataclasses.asdict(cfg))
    return root


def test_load_run_agent_trains_once_then_loads(tiny_run, capsys):
    run = tiny_run / "tiny"
    agent, params, method = load_run_agent(run, "lift", "EBC", 0, ckpt_dir=tiny_run / "ckpt", progress=False)
    assert "training it now" in capsys.readouterr().err
    again, params2, _ = load_run_agent(run, "lift", "EBC", 0, ckpt_dir=tiny_run / "ckpt", progress=False)
    assert "training" not in capsys.readouterr().err
    assert method.name == "EBC" and again == agent and agent.config.normalize is False and agent.obs_size == 19
    for a, b in zip(jax.tree_util.tree_leaves(params), jax.tree_util.tree_leaves(params2)):
        np.testing.assert_array_equal(a, b)
    cfg = load_sweep_config(run / "config.json")
    assert cfg.methods == ("EBC",)
    with pytest.raises(ConfigError, match=r"tiny/config.json: field 'methods' has no 'POIR-DRIL'"):
        load_run_agent(run, "lift", "POIR-DRIL", 0, ckpt_dir=tiny_run / "ckpt")
    with pytest.raises(ConfigError, match=r"field 'seeds' has no 3"):
        load_run_agent(run, "lift", "EBC", 3, ckpt_dir=tiny_run / "ckpt")


@pytest.mark.slow
def test_render_video_of_a_run_cell(tiny_run, tmp_path):
    """The whole path: the run's agent, the cell's episode in MJX (one compile), frames, MP4."""
    cfg = VideoConfig(run=tiny_run / "tiny", method="EBC", sigma_init=0.3, episodes=(1,), steps=3, width=W, height=H,
                      out=tmp_path / "v.mp4", checkpoints=tiny_run / "ckpt")  # fmt: skip
    path = render_video(cfg, progress=False)
    video = read_mp4(path)
    assert video.shape == (3, H, W, 3)
    assert video[0, H // 2 :].std() > 10  # a scene, not a blank frame


@pytest.mark.parametrize("backend", ["osmesa", "glx"])
def test_missing_gl_library_is_one_line_and_exit_2(backend, tmp_path):
    if backend == "osmesa" and ctypes.util.find_library("OSMesa"):
        pytest.skip("OSMesa is installed here: MUJOCO_GL=osmesa would work")
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "PYOPENGL_PLATFORM")}
    env["MUJOCO_GL"] = backend  # glx without a display cannot open a context
    p = subprocess.run([sys.executable, "-m", "poir_mjx.cli", "video", "--run", str(tmp_path)], cwd=ROOT, env=env,
                       capture_output=True, text=True, timeout=120)  # fmt: skip
    assert p.returncode == 2, p.stderr
    errors = [line for line in p.stderr.splitlines() if line.strip()]
    assert len(errors) == 1 and errors[0].startswith("error: ") and "apt-get install" in errors[0], p.stderr


_IMPORT_WITHOUT_EGL = """
import ctypes.util, os
real = ctypes.util.find_library
ctypes.util.find_library = lambda name: None if name == "EGL" else real(name)
import poir_mjx.video
print(os.environ.get("MUJOCO_GL"))
import mujoco
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="MUJOCO_GL=egl is chosen on Linux only")
@pytest.mark.parametrize("egl", [True, False])
def test_egl_chosen_only_where_libegl_is_found(egl):
    """A machine without libEGL (the lent GPU's image) must still import mujoco: MUJOCO_GL=egl there made
    `import mujoco` raise AttributeError in PyOpenGL, so every command failed, not only `video`."""
    if egl and not ctypes.util.find_library("EGL"):
        pytest.skip("no libEGL here")
    env = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}
    code = _IMPORT_WITHOUT_EGL if not egl else "import os, poir_mjx.video; print(os.environ.get('MUJOCO_GL'))"
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split()[0] == ("egl" if egl else "None")
