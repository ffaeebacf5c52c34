"""Holes a user's probing found: stale cells, run names, bad fields, unreadable files, file modes."""

import json
import os

import h5py
import pytest

from poir_mjx import cli
from poir_mjx.atomic import atomic_write_text
from poir_mjx.core.config import ConfigError
from poir_mjx.data.demos import demo_path
from poir_mjx.data.robomimic import DatasetError, read_transitions, write_robomimic
from poir_mjx.eval import run_folder
from poir_mjx.eval.artifacts import content_digest, read_cell
from poir_mjx.eval.sweep_config import load_sweep_config
from tests.data.test_robomimic import ENV_ARGS, make_demo

BASE = {"name": "x", "tasks": ["lift"], "methods": ["EBC"]}


def _config(tmp_path, **fields):
    f = tmp_path / "c.json"
    f.write_text(json.dumps({**BASE, **fields}))
    return f


def test_a_replaced_demo_file_gets_another_digest(tmp_path):
    path = write_robomimic(tmp_path / "d.hdf5", [make_demo(5, 0), make_demo(4, 1)], ENV_ARGS)
    first = content_digest(path, "lift")
    write_robomimic(tmp_path / "d.hdf5", [make_demo(5, 0), make_demo(4, 1)], ENV_ARGS)  # the same data again
    assert content_digest(path, "lift") == first
    with h5py.File(path, "r+") as f:  # other data at the same path
        f["data/demo_1/actions"][0, 0] = 0.5
    assert content_digest(path, "lift") != first
    with h5py.File(path, "r+") as f:  # a NaN-corrupted copy: refused, never keyed
        f["data/demo_1/actions"][0, 0] = float("nan")
    with pytest.raises(DatasetError, match="demo_1: actions: NaN or inf at row 0"):
        content_digest(path, "lift")


@pytest.mark.parametrize("name", ["../../x", "", "a/b", ".hidden", "cpu small"])
def test_run_names_must_be_plain_folder_names(tmp_path, name):
    with pytest.raises(ConfigError, match="field 'name' must be a plain folder name"):
        load_sweep_config(_config(tmp_path, name=name))


def test_a_different_config_cannot_mix_into_an_existing_run_folder(tmp_path):
    out = tmp_path / "results" / "run"
    run_folder.prepare(out, {"episodes": 10})
    run_folder.prepare(out, {"episodes": 10})  # the same config again: fine (resume)
    with pytest.raises(ConfigError, match=r"config.json: this run folder was made with a different config \(fields \['episodes'\]\)"):
        run_folder.prepare(out, {"episodes": 20})
    run_folder.prepare(out, {"episodes": 20}, replace_config=True)
    assert json.loads((out / "config.json").read_text()) == {"episodes": 20}


def test_an_unwritable_results_folder_is_refused_before_any_work(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(ConfigError, match="results folder is not writable"):
        run_folder.prepare(blocker / "run", {})
    rc = cli.main(["sweep", "--config", str(_config(tmp_path)), "--results", str(blocker)])
    err = capsys.readouterr().err
    assert rc == 2 and "results folder is not writable" in err and err.count("\n") == 1


@pytest.mark.parametrize(
    "fields, match",
    [
        ({"epochs": -1}, "field 'epochs' must be positive"),
        ({"demo_files": {"pick_place_can": "c.json"}}, "field 'demo_files': task 'pick_place_can' is not in field 'tasks'"),
        ({"demo_files": {"lift": "."}}, r"field 'demo_files.lift': \. is a directory"),
    ],
)
def test_bad_fields_name_the_field(tmp_path, monkeypatch, fields, match):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match=match):
        load_sweep_config(_config(tmp_path, **fields))


def test_a_directory_is_not_reported_as_missing(tmp_path):
    with pytest.raises(DatasetError, match="is a directory"):
        read_transitions(tmp_path)
    with pytest.raises(ConfigError, match="is a directory"):
        load_sweep_config(tmp_path)


def test_a_cell_file_that_is_not_an_object_is_one_clear_error(tmp_path):
    cell = tmp_path / "cell.json"
    cell.write_text("[1, 2]")
    with pytest.raises(ConfigError, match="cell.json: not a cell record"):
        read_cell(cell, "abc")
    cell.write_text("{not json")
    with pytest.raises(ConfigError, match="cell.json: not a readable cell record"):
        read_cell(cell, "abc")
    assert read_cell(tmp_path / "absent.json", "abc") is None


def test_array_valued_attributes_are_one_clear_error(tmp_path):
    path = write_robomimic(tmp_path / "d.hdf5", [make_demo(5, 0)], ENV_ARGS)
    with h5py.File(path, "r+") as f:
        f["data"].attrs["poir_mjx_generator"] = [1.0, 2.0]
    assert read_transitions(path).provenance["poir_mjx_generator"] == [1.0, 2.0]
    with h5py.File(path, "r+") as f:
        f["data"].attrs["env_args"] = [1, 2, 3]
    with pytest.raises(DatasetError, match=r"d.hdf5: data.attrs\['env_args'\]: expected a JSON string"):
        read_transitions(path)


def test_results_are_ordinary_files(tmp_path):
    old = os.umask(0o022)
    try:
        atomic_write_text(tmp_path / "t.md", "x")
    finally:
        os.umask(old)
    assert (tmp_path / "t.md").stat().st_mode & 0o777 == 0o644


def test_other_demo_counts_never_overwrite_the_shared_file(tmp_path):
    assert demo_path("lift", tmp_path).name == "lift.hdf5"
    assert demo_path("lift", tmp_path, "robosuite", 50).name == "lift-n50.hdf5"
    assert demo_path("lift", tmp_path, "mjx", 200).name == "lift-mjx.hdf5"
