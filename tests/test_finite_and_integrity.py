"""NaN never passes as a result (demo data in float32, training losses, checkpoint weights), and a checkpoint is
verified when read (the older unchecksummed format refused; a file that is not a checkpoint is not called damaged)."""

import dataclasses
import json

import h5py
import jax
import numpy as np
import pytest

from poir_mjx import checkpoint_codec as codec
from poir_mjx import cli
from poir_mjx.core import checkpoint
from poir_mjx.core.agent import POIR, TrainingDivergedError
from poir_mjx.core.config import ConfigError
from poir_mjx.data.robomimic import DatasetError, read_transitions, write_robomimic
from tests.helpers import ENV_ARGS, expert_data, make_demo, one_line_error, tiny_config


@pytest.fixture
def demo_file(tmp_path):
    return write_robomimic(tmp_path / "lift.hdf5", [make_demo(5, 0), make_demo(4, 1)], ENV_ARGS)


def _edit(path, fn):
    with h5py.File(path, "r+") as f:
        fn(f)
    return path


@pytest.mark.parametrize("edit, match", [
    (lambda f: f["data/demo_1/obs/object"].__setitem__((2, 0), 1e39),
     r"demo_1: obs/object: NaN or inf at row 2 \(in float32"),  # finite in float64, inf in float32
    (lambda f: (f["data/demo_0"].__delitem__("actions"),
                f["data/demo_0"].create_dataset("actions", data=np.ones((5, 7)) * (1 + 1j))),
     r"demo_0: actions: not real numbers \(dtype complex128\)"),
    (lambda f: (f["data/demo_0/obs"].__delitem__("object"), f["data/demo_0/obs"].create_group("object")),
     r"demo_0: obs/object: is a group, expected a dataset"),
    (lambda f: f["data/demo_0"].attrs.__setitem__("num_samples", "five"),
     r"demo_0: attrs\['num_samples'\]: must be an integer, got 'five'"),
    (lambda f: f["data/demo_0"].attrs.__setitem__("num_samples", float("nan")),
     r"demo_0: attrs\['num_samples'\]: must be an integer"),
    (lambda f: (f["data/demo_0/obs"].__delitem__("object"),
                f["data/demo_0/obs"].__setitem__("object", h5py.ExternalLink("gone.hdf5", "/x"))),
     r"demo_0: obs/object: (cannot be read|missing dataset)"),
])  # fmt: skip
def test_bad_demo_fields_are_one_line_naming_the_field(demo_file, edit, match):
    _edit(demo_file, edit)
    with pytest.raises(DatasetError, match=match) as e:
        read_transitions(demo_file, task="lift")
    assert "\n" not in str(e.value) and str(demo_file) in str(e.value)


def test_a_diverging_training_stops_with_one_line():
    obs, act, nxt = expert_data(n_demos=4, steps=10)
    small = tiny_config(k=2, width=8, epochs=2, batch=16)
    cfg = dataclasses.replace(small, train=dataclasses.replace(small.train, epochs=6, learning_rate=1e30))
    with pytest.raises(TrainingDivergedError, match=r"train: the bc ensemble's loss is .* training diverged \(field "
                                                    r"'train.learning_rate' is 1e\+30\); nothing was recorded"):
        POIR(cfg, 2, 2).fit(jax.random.PRNGKey(0), obs, act, nxt)
    with pytest.raises(TrainingDivergedError):  # inputs whose normalised values overflow do the same
        POIR(small, 2, 2).fit(jax.random.PRNGKey(0), obs, act * 3e38, nxt)
    with pytest.raises(ConfigError, match="train.batch_size: 64 exceeds the 40 expert transitions"):
        POIR(tiny_config(k=2, width=8, epochs=1, batch=64), 2, 2).fit(jax.random.PRNGKey(0), obs, act, nxt)


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    obs, act, nxt = expert_data(n_demos=4, steps=10)
    agent = POIR(tiny_config(k=2, width=8, epochs=1, batch=16), 2, 2)
    params, _ = agent.fit(jax.random.PRNGKey(0), obs, act, nxt)
    return checkpoint.save(tmp_path_factory.mktemp("ck") / "agent.ckpt", agent, params, {"task": "lift"})


def _rewrite(path, out, fn, checksum=True):
    blob = dict(codec.read(path, checkpoint.FORMAT))
    fn(blob)
    if checksum:
        return codec.write(out, blob.pop("format"), blob)
    from flax import serialization

    out.write_bytes(serialization.msgpack_serialize(blob))
    return out


def test_nan_weights_under_a_valid_checksum_are_refused(saved, tmp_path):
    def poison(blob):
        dense = blob["params"]["bc"]["params"]["Dense_0"]
        dense["kernel"] = np.array(dense["kernel"])
        dense["kernel"][0, 0, 0] = np.nan

    bad = _rewrite(saved, tmp_path / "nan.ckpt", poison)
    with pytest.raises(codec.CheckpointError, match=r"nan.ckpt: field 'params.bc.params.Dense_0.kernel' holds NaN or "
                                                    r"inf \(entry \[0, 0, 0\]\)"):  # fmt: skip
        checkpoint.load(bad)

    def overflow(blob):  # float64 weights that are inf once cast to float32
        blob["params"]["bc"]["params"]["Dense_0"]["bias"] = blob["params"]["bc"]["params"]["Dense_0"]["bias"].astype(
            np.float64) * 0 + 1e39  # fmt: skip

    with pytest.raises(codec.CheckpointError, match="Dense_0.bias' holds NaN or inf"):
        checkpoint.load(_rewrite(saved, tmp_path / "big.ckpt", overflow))


def test_the_older_format_without_a_checksum_is_refused(saved, tmp_path):
    def edit(blob):  # an edit nothing can detect without a checksum
        dense = blob["params"]["bc"]["params"]["Dense_0"]
        dense["kernel"] = np.array(dense["kernel"]) + 1.0

    old = _rewrite(saved, tmp_path / "old.ckpt", edit, checksum=False)
    with pytest.raises(codec.CheckpointError, match=r"old.ckpt: written before checkpoints carried a sha256"):
        checkpoint.load(old)


def test_eval_of_a_cell_record_does_not_advise_deleting_it(tmp_path, capsys):
    record = tmp_path / "si=0.02_sa=0_seed=0.json"
    record.write_text(json.dumps({"config_hash": "h", "episodes": 10, "successes": 3}))
    before = record.read_bytes()
    assert cli.main(["eval", "--ckpt", str(record), "--episodes", "1"]) == 2
    line = one_line_error(capsys)
    assert "not a poir-mjx checkpoint" in line and "delete" not in line and record.read_bytes() == before
