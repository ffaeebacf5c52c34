"""robomimic HDF5: round trip, and one clear error per kind of bad input (naming file, demo, field)."""

import json

import h5py
import numpy as np
import pytest

from poir_mjx.data.robomimic import DatasetError, read_transitions, write_robomimic
from tests.helpers import ENV_ARGS, make_demo

@pytest.fixture
def good(tmp_path):
    demos = [make_demo(5, 0), make_demo(3, 1), make_demo(4, 2)]
    path = write_robomimic(tmp_path / "lift.hdf5", demos, ENV_ARGS, masks={"train": ["demo_0", "demo_2"], "valid": ["demo_1"]},
                           extra_attrs={"generator": {"expert": "scripted", "simulator": "robosuite"}})
    return path, demos


def test_round_trip(good):
    path, demos = good
    tr = read_transitions(path, task="lift")
    assert tr.num_transitions == 12 and tr.demo_lengths.tolist() == [5, 3, 4] and tr.demo_starts.tolist() == [0, 5, 8]
    assert tr.obs_sizes == (3, 4, 2, 10)
    np.testing.assert_allclose(tr.obs[5:8, :3], demos[1].obs["robot0_eef_pos"], rtol=1e-6)
    np.testing.assert_allclose(tr.next_obs[8:, 9:], demos[2].next_obs["object"], rtol=1e-6)
    np.testing.assert_allclose(tr.actions[:5], demos[0].actions, rtol=1e-6)
    assert tr.env_args == ENV_ARGS and tr.provenance["generator"]["simulator"] == "robosuite"
    with h5py.File(path) as f:  # robomimic's exact layout
        assert f["data"].attrs["total"] == 12 and json.loads(f["data"].attrs["env_args"]) == ENV_ARGS
        assert f["data/demo_1"].attrs["num_samples"] == 3
        assert f["data/demo_1/states"].shape == (3, 33) and f["data/demo_1/dones"][-1] == 1
        assert [x.decode() for x in f["mask/train"][()]] == ["demo_0", "demo_2"]
    tr = read_transitions(path, filter_key="valid", obs_keys=("object",))
    assert tr.demo_names == ["demo_1"] and tr.obs.shape == (3, 10)
    assert not list(path.parent.glob(".*.tmp"))


def corrupt(path, fn):
    with h5py.File(path, "r+") as f:
        fn(f)
    return path


@pytest.mark.parametrize(
    "mutate, match",
    [
        (lambda f: f["data/demo_1/obs"].__delitem__("object"), r"demo_1: obs/object: missing dataset"),
        (lambda f: f["data/demo_2"].__delitem__("next_obs"), r"demo_2: next_obs: missing group"),
        (lambda f: (f["data/demo_0/obs"].__delitem__("object"), f["data/demo_0/obs"].create_dataset("object", data=np.zeros((4, 10)))),
         r"demo_0: obs/object: length 4 differs from actions length 5"),
        (lambda f: (f["data/demo_1"].__delitem__("actions"), f["data/demo_1"].create_dataset("actions", data=np.zeros((3, 6)))),
         r"demo_1: actions: action size 6, expected 7"),
        (lambda f: f["data/demo_2/actions"].__setitem__((1, 2), np.nan), r"demo_2: actions: NaN or inf at row 1"),
        (lambda f: f["data/demo_0/next_obs/robot0_eef_pos"].__setitem__((0, 0), np.inf), r"demo_0: next_obs/robot0_eef_pos: NaN or inf"),
        (lambda f: (f["data/demo_1"].__delitem__("actions"), f["data/demo_1"].create_dataset("actions", data=np.zeros((0, 7)))),
         r"demo_1: actions: empty demo"),
        (lambda f: f["data"].__delitem__("demo_0"), None),
    ],
)
def test_each_bad_input_is_one_clear_error(good, mutate, match):
    path, _ = good
    before = path.read_bytes()
    corrupt(path, mutate)
    after = path.read_bytes()
    if match is None:  # filter naming a missing demo
        with pytest.raises(DatasetError, match=r"lift\.hdf5: demo_0: mask/train: filter lists demo 'demo_0'"):
            read_transitions(path, filter_key="train")
        return
    with pytest.raises(DatasetError, match=r"lift\.hdf5: " + match):
        read_transitions(path)
    assert path.read_bytes() == after != before  # the reader never writes


def test_env_args_for_another_task(good):
    path, _ = good
    with pytest.raises(DatasetError, match=r"env_name: is 'Lift', expected 'PickPlaceCan'"):
        read_transitions(path, task="pick_place_can")


def test_missing_filter_and_not_hdf5(good, tmp_path):
    path, _ = good
    with pytest.raises(DatasetError, match="mask/20_percent: missing filter key"):
        read_transitions(path, filter_key="20_percent")
    bad = tmp_path / "x.hdf5"
    bad.write_text("hello")
    with pytest.raises(DatasetError, match="x.hdf5: not an HDF5 file"):
        read_transitions(bad)
    with pytest.raises(DatasetError, match="no such file"):
        read_transitions(tmp_path / "none.hdf5")
