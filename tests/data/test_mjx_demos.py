"""Expert demonstrations generated in MJX (no robosuite): a valid robomimic file saying MJX, successful episodes only."""

import json

import h5py
import numpy as np
import pytest

from poir_mjx.data.demos import demo_path, generate
from poir_mjx.data.robomimic import read_transitions


@pytest.mark.slow
@pytest.mark.current_stack
def test_mjx_demos_are_successful_episodes_in_robomimic_layout(tmp_path, capsys):
    path = generate("lift", num=2, seed=0, sigma_init=0.02, out=tmp_path, progress=False, simulator="mjx", batch=2)
    assert path == demo_path("lift", tmp_path, "mjx", 2) and path.name == "lift-mjx-n2.hdf5"  # never the shared 200-demo file
    tr = read_transitions(path, task="lift")
    assert len(tr.demo_names) == 2 and tr.obs.shape[1] == 19 and tr.actions.shape[1] == 7
    n0 = int(tr.demo_lengths[0])
    np.testing.assert_allclose(tr.next_obs[: n0 - 1], tr.obs[1:n0], atol=1e-6)  # s' of step t is s of t+1
    assert np.all(np.abs(tr.actions) <= 1.0)
    with h5py.File(path) as f:
        gen = json.loads(f["data"].attrs["poir_mjx_generator"])
        assert gen["simulator"].startswith("MJX (mujoco-mjx") and "float32" in gen["simulator"]
        assert json.loads(f["data"].attrs["env_args"])["env_version"] == "mjx"
        for name in ("demo_0", "demo_1"):
            d = f["data"][name]
            rewards = d["rewards"][()]
            # A robosuite-style demo: success first reached 4 steps before its end, and kept.
            assert rewards[-1] == 1 and rewards[-5] == 1 and (len(rewards) < 5 or rewards[0] == 0)
            assert d["dones"][-1] == 1 and d["states"].shape[0] == d["actions"].shape[0]
            assert "<mujoco" in d.attrs["model_file"]
        cube_z = f["data/demo_0/obs/object"][()][:, 2]
        assert cube_z[-1] - cube_z[0] > 0.04  # the cube was lifted (robosuite's margin is 4 cm)
    mtime = path.stat().st_mtime_ns
    generate("lift", num=2, seed=0, sigma_init=0.02, out=tmp_path, progress=False, simulator="mjx", batch=2)
    assert path.stat().st_mtime_ns == mtime and "skipped" in capsys.readouterr().out


@pytest.mark.slow
def test_human_like_mjx_demos_are_the_robosuite_paths_actions_for_the_same_key(tmp_path):
    """Two human-like Lift demos recorded in MJX (vmapped, lax.scan): the robosuite recorder's jitted expert, given the
    episode's key and the demo's own observations, acts bit for bit the same, and the record names the style. (The
    two simulators' episodes differ in their initial states and keys, so the check is on the same inputs.)"""
    import jax

    from poir_mjx.data.expert_episodes import _jit_expert
    from poir_mjx.data.robomimic import LOW_DIM_KEYS

    path = generate("lift", num=2, seed=0, sigma_init=0.02, out=tmp_path, progress=False, simulator="mjx", batch=2,
                    style="human_like")  # fmt: skip
    assert path.name == "lift-mjx-human-n2.hdf5"
    init, act = _jit_expert("lift", "human_like")
    with h5py.File(path) as f:
        assert json.loads(f["data"].attrs["poir_mjx_generator"])["demo_style"] == "human_like"
        for j in range(2):
            g = f[f"data/demo_{j}"]
            # the rollout's policy key: split(episode key)[1] (rollout/episode.py), episode key fold_in(seed, j)
            st = init(jax.random.split(jax.random.fold_in(jax.random.PRNGKey(0), j))[1])
            out = []
            for t in range(g["actions"].shape[0]):
                a, st = act({k: g["obs"][k][t] for k in LOW_DIM_KEYS}, st)
                out.append(np.asarray(a))
            np.testing.assert_array_equal(np.stack(out), g["actions"][()])
