"""The compact copy of a robomimic file trains on the same transitions as its source."""

import h5py
import numpy as np
import pytest

from poir_mjx import cli
from poir_mjx.data.compact import compact
from poir_mjx.data.robomimic import DatasetError, read_transitions, write_robomimic
from poir_mjx.sweep.artifacts import transitions_digest
from tests.helpers import ENV_ARGS, make_demo


def test_the_compact_copy_reads_as_the_same_transitions_and_is_smaller(tmp_path):
    src = write_robomimic(tmp_path / "lift.hdf5", [make_demo(20, s) for s in range(6)], ENV_ARGS,
                          extra_attrs={"poir_mjx_generator": "{}"})  # fmt: skip
    dst = compact(src, tmp_path / "out" / "lift.hdf5")
    a, b = read_transitions(src), read_transitions(dst)
    assert transitions_digest(a) == transitions_digest(b)
    np.testing.assert_array_equal(a.obs, b.obs)
    assert b.env_args == a.env_args and dst.stat().st_size < src.stat().st_size
    with h5py.File(dst) as f:
        assert "states" not in f["data/demo_0"] and "model_file" not in f["data/demo_0"].attrs


def test_compact_errors_are_one_line_naming_the_file(tmp_path, capsys):
    src = write_robomimic(tmp_path / "lift.hdf5", [make_demo(5, 0)], ENV_ARGS)
    with pytest.raises(DatasetError, match="cannot replace its source"):
        compact(src, src)
    with h5py.File(src, "a") as f:
        del f["data/demo_0/obs/object"]
    assert cli.main(["demos", "compact", "--data", str(src), "--out", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "lift.hdf5: field 'data/demo_0/obs/object' is missing" in err[0]
    assert not (tmp_path / "c" / "lift.hdf5").exists()
