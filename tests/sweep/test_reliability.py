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
from poir_mjx.sweep import run_folder
from poir_mjx.sweep.artifacts import content_digest, read_cell
from poir_mjx.sweep.config import load_sweep_config
from tests.helpers import ENV_ARGS, make_demo

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


@pytest.mark.parametrize("name", ["../../x", "", "a/b", ".hidden", "cpu small", "run\n"])
def test_run_names_must_be_plain_folder_names(tmp_path, name):
    with pytest.raises(ConfigError, match="field 'name': must be a plain folder name"):
        load_sweep_config(_config(tmp_path, name=name))


def test_a_different_config_cannot_mix_into_an_existing_run_folder(tmp_path):
    out = tmp_path / "results" / "run"
    run_folder.prepare(out, {"episodes": 10, "ranking": "balanced"})
    (out / "cells").mkdir()
    (out / "cells" / "c.json").write_text("{}")  # a cell made with it
    run_folder.prepare(out, {"episodes": 10, "ranking": "balanced"})  # the same config again: fine (resume)
    with pytest.raises(ConfigError, match=r"config.json: this run folder was made with a different config \(fields \['episodes'\]\)"):
        run_folder.prepare(out, {"episodes": 20, "ranking": "balanced"})
    run_folder.prepare(out, {"episodes": 20, "ranking": "balanced"}, replace_config=True)
    assert json.loads((out / "config.json").read_text()) == {"episodes": 20, "ranking": "balanced"}


def test_an_unwritable_results_folder_is_refused_before_any_work(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(ConfigError, match="results folder is not writable"):
        run_folder.prepare(blocker / "run", {})
    rc = cli.main(["sweep", "--config", str(_config(tmp_path)), "--results", str(blocker)])
    err = capsys.readouterr().err
    assert rc == 2 and "--results: " in err and "is a file, expected a folder" in err and err.count("\n") == 1


@pytest.mark.parametrize(
    "fields, match",
    [
        ({"epochs": 3}, r"c.json: field 'epochs' is no longer a sweep field; use \"overrides\": \{\"train.epochs\": N\}"),
        ({"demo_files": {"pick_place_can": "c.json"}}, "field 'demo_files': task 'pick_place_can' is not in field 'tasks'"),
        ({"demo_files": {"lift": "."}}, r"field 'demo_files.lift': \. is a directory"),
        ({"demo_files": {"lift": 5}}, r"field 'demo_files.lift': must be a file path \(a string\), got 5"),
        ({"sigma_init": [0.05, 0.05]}, "field 'sigma_init': lists 0.05 more than once"),
        ({"methods": ["EBC", "EBC"]}, "field 'methods': lists 'EBC' more than once"),
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


def test_a_published_run_folder_is_never_overwritten_by_another_config(tmp_path):
    """Tables without a config (made by hand or an older version) are refused; a published run's committed
    config.json guards it like any run's."""
    out = tmp_path / "results" / "cpu-small"
    out.mkdir(parents=True)
    (out / "lift.md").write_text("| method | ... |\n")
    with pytest.raises(ConfigError, match="holds results but no config.json"):
        run_folder.prepare(out, {"episodes": 20})
    (out / "config.json").write_text(json.dumps({"episodes": 20}))
    run_folder.prepare(out, {"episodes": 20})  # the published config itself: fine
    with pytest.raises(ConfigError, match="made with a different config"):
        run_folder.prepare(out, {"episodes": 5})


def test_published_runs_commit_their_config():
    from pathlib import Path

    root = Path(__file__).resolve().parents[2] / "results"
    for md in root.glob("*/lift.md"):
        assert (md.parent / "config.json").is_file(), md.parent


def test_a_refused_runs_config_does_not_block_the_corrected_one(tmp_path):
    out = tmp_path / "run"
    run_folder.prepare(out, {"episodes": 10})  # then refused later (no cell made)
    run_folder.prepare(out, {"episodes": 12})  # the corrected config: the folder holds nothing to mix with
    assert json.loads((out / "config.json").read_text()) == {"episodes": 12}


def test_a_config_that_is_not_an_object_is_one_clear_error(tmp_path):
    out = tmp_path / "run"
    (out / "cells").mkdir(parents=True)
    (out / "cells" / "c.json").write_text("{}")
    (out / "config.json").write_text("[1, 2]")
    with pytest.raises(ConfigError, match=r"config.json: not a sweep config \(expected a JSON object, got list\)"):
        run_folder.prepare(out, {"episodes": 10})


@pytest.mark.parametrize("fields, match", [
    ({"successes": 7, "episodes": 5}, "field 'successes' \\(7\\) exceeds field 'episodes' \\(5\\)"),
    ({"episodes": 5}, "field 'successes' must be a count"),
    ({"successes": "3", "episodes": 5}, "field 'successes' must be a count"),
])  # fmt: skip
def test_a_cell_record_with_bad_counts_is_one_clear_error(tmp_path, fields, match):
    cell = tmp_path / "cell.json"
    cell.write_text(json.dumps({"config_hash": "abc", **fields}))
    with pytest.raises(ConfigError, match=match):
        read_cell(cell, "abc")


def test_demos_generate_checks_its_flags_first(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    for args, msg in ((["--sigma-init", "-1"], "--sigma-init: must be >= 0"),
                      (["--out", str(f)], "is a file, expected a folder")):  # fmt: skip
        assert cli.main(["demos", "generate", "--tasks", "lift", *args]) == 2
        err = capsys.readouterr().err
        assert msg in err and err.count("\n") == 1


def test_eval_checks_its_output_before_evaluating(tmp_path, capsys):
    assert cli.main(["eval", "--ckpt", str(tmp_path / "none.ckpt"), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "--out:" in err and "is a directory, expected a file name" in err


@pytest.mark.parametrize("blocked", ["cells/lift/EBC", "ckpt"])
def test_unwritable_cell_and_checkpoint_folders_are_refused_before_any_work(tmp_path, capsys, blocked):
    """A folder the run would write late (a cell's, the checkpoints') is checked first: one line, nothing done."""
    results, ckpt = tmp_path / "results", tmp_path / "ckpt"
    target = results / "x" / blocked if blocked.startswith("cells") else ckpt
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text("a file where the folder must go")
    rc = cli.main(["sweep", "--config", str(_config(tmp_path)), "--results", str(results), "--checkpoints", str(ckpt),
                   "--data", str(tmp_path / "data")])  # fmt: skip
    err = capsys.readouterr().err
    assert rc == 2 and ("is not writable" in err or "is a file, expected a folder" in err) and err.count("\n") == 1
    assert not (tmp_path / "data").exists()  # no demos were made


def test_a_field_given_twice_is_refused(tmp_path):
    f = tmp_path / "c.json"
    f.write_text('{"name": "x", "episodes": 5, "tasks": ["lift"], "episodes": 50}')
    with pytest.raises(ConfigError, match="field 'episodes' is given more than once"):
        load_sweep_config(f)


def test_a_run_folder_recorded_with_epochs_is_migrated_and_accepted(tmp_path):
    """Run folders made while the sweep config had `epochs`: 0 is dropped, N becomes the override train.epochs;
    the folder is not "a different config", and the POIR config (so every cell's hash) is what `epochs` gave."""
    import dataclasses

    from poir_mjx.core.config import preset
    from poir_mjx.sweep.config import SweepConfig, base_config

    for epochs, overrides in ((0, {}), (3, {"train.epochs": 3})):
        cfg = SweepConfig(name=f"old{epochs}", overrides=overrides, ranking="paper")  # the ranking of its day
        out = tmp_path / cfg.name
        (out / "cells").mkdir(parents=True)
        (out / "cells" / "c.json").write_text("{}")
        old = {**json.loads(json.dumps(dataclasses.asdict(cfg))), "epochs": epochs, "overrides": {}}
        (out / "config.json").write_text(json.dumps(old))
        run_folder.prepare(out, dataclasses.asdict(cfg), defaults=dataclasses.asdict(SweepConfig(name=cfg.name)))
        assert "epochs" not in json.loads((out / "config.json").read_text())
        (out / "config.json").write_text(json.dumps(old))
        loaded = load_sweep_config(out / "config.json", recorded=True)
        assert loaded == cfg
        before = preset("cpu-small")  # what `epochs` did: the preset's train.epochs replaced when > 0
        if epochs:
            before = dataclasses.replace(before, train=dataclasses.replace(before.train, epochs=epochs))
        assert base_config(loaded) == before
    assert run_folder.upgrade_recorded({"epochs": 5, "overrides": {"train.epochs": 7}}) == {
        "overrides": {"train.epochs": 7}, "ranking": "paper"}

