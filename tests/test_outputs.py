"""Every output path checked in one place before any work (poir_mjx/outputs.py), and one process per run folder
(poir_mjx/folder_lock.py)."""

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from poir_mjx import cli
from poir_mjx.core.config import ConfigError
from poir_mjx.folder_lock import locked
from poir_mjx.outputs import check_file, published_run
from tests.helpers import PUBLISHED, one_line_error, project, snapshot

ROOT = Path(__file__).resolve().parents[1]


def test_every_command_says_what_it_writes():
    """The class, not the example: a command added to the registry must list its outputs for the one check."""
    for c in cli.COMMANDS:
        assert callable(getattr(c.options_type(), "outputs", None)), c.name


def test_a_published_run_is_the_folder_whose_config_git_tracks(tmp_path):
    root = project(tmp_path)
    run = root / "results" / PUBLISHED
    assert published_run(run / "cells" / "lift" / "new.json") == run.resolve()
    (root / "results" / "local").mkdir()
    (root / "results" / "local" / "config.json").write_text("{}")  # not tracked: a local run
    assert published_run(root / "results" / "local" / "lift.md") is None
    (root / "results" / "alias").symlink_to(run)  # a link into it is the same folder
    assert published_run(root / "results" / "alias" / "lift.md") == run.resolve()


def test_the_projects_own_published_runs_are_recognised():
    assert published_run(ROOT / "results" / "cpu-small" / "lift.md") == (ROOT / "results" / "cpu-small").resolve()


def _sweep_config(tmp_path, name, **fields):
    f = tmp_path / f"{name}.json"
    f.write_text(json.dumps({"name": name, "tasks": ["lift"], "methods": ["EBC"], **fields}))
    return str(f)


@pytest.mark.parametrize("extra", [[], ["--replace-config"]])
def test_a_sweep_never_writes_a_published_run(tmp_path, capsys, monkeypatch, extra):
    root = project(tmp_path)
    monkeypatch.chdir(root)
    before = snapshot(root)
    rc = cli.main(["sweep", "--config", _sweep_config(tmp_path, PUBLISHED, episodes=3), *extra])
    assert rc == 2 and "is read-only" in one_line_error(capsys)
    assert snapshot(root) == before


def test_a_symlink_out_of_a_run_folder_is_refused(tmp_path, capsys, monkeypatch):
    root = project(tmp_path)
    monkeypatch.chdir(root)
    mine = root / "results" / "mine" / "cells" / "lift"
    mine.mkdir(parents=True)
    (mine / "EBC").symlink_to(root / "results" / PUBLISHED / "cells" / "lift" / "EBC")
    before = snapshot(root)
    assert cli.main(["sweep", "--config", _sweep_config(tmp_path, "mine")]) == 2
    assert "a symbolic link out of the run folder" in one_line_error(capsys)
    assert snapshot(root) == before


def test_a_table_that_is_a_directory_is_refused_before_any_work(tmp_path, capsys, monkeypatch):
    root = project(tmp_path)
    monkeypatch.chdir(root)
    (root / "results" / "mine" / "lift.md").mkdir(parents=True)
    assert cli.main(["sweep", "--config", _sweep_config(tmp_path, "mine")]) == 2
    assert "lift.md is a directory" in one_line_error(capsys)
    assert not (root / "results" / "mine" / "config.json").exists()


@pytest.mark.parametrize("argv", [
    ["eval", "--ckpt", "x.ckpt", "--out", "/dev/full"],
    ["compare", "results/pub", "--out", "FIFO"],
    ["report", "--out", "FIFO"],
    ["compare", "results/pub", "--out", "results/pub/lift.md"],
    ["eval", "--ckpt", "x.ckpt", "--out", "results/pub/new.md"],
    ["eval", "--ckpt", "x.ckpt", "--out", "LINK"],
    ["report", "--results", "results/pub"],
    ["bench", "env", "--name", "../pub/lift"],
    ["bench", "planner", "--out", "results/pub"],
    ["demos", "generate", "--out", "results/pub/cells"],
    ["demos", "success", "--out", "/dev/null"],
    ["gpu-check", "--dry-run", "--out", "results/pub"],
    ["sweep", "--config", "c.json", "--checkpoints", "results/pub/ck"],
])  # fmt: skip
def test_every_writing_command_refuses_a_bad_output_before_any_work(tmp_path, capsys, monkeypatch, argv):
    root = project(tmp_path)
    monkeypatch.chdir(root)
    os.mkfifo(root / "FIFO")
    (root / "LINK").symlink_to(root / "results" / PUBLISHED / "lift.md")
    (root / "c.json").write_text(json.dumps({"name": "mine"}))
    before = snapshot(root)
    assert cli.main(argv) == 2
    line = one_line_error(capsys)
    assert any(w in line for w in ("--out", "--name", "--checkpoints", "--results")), line
    assert snapshot(root) == before and (root / "FIFO").is_fifo()


def test_check_file_accepts_an_ordinary_file(tmp_path):
    check_file(tmp_path / "new" / "table.md", "--out")
    (tmp_path / "t.md").write_text("x")
    check_file(tmp_path / "t.md", "--out")


def test_a_second_process_on_a_run_folder_gets_one_line(tmp_path):
    with locked(tmp_path / "run"):
        with pytest.raises(ConfigError, match=rf"run: another process \(pid {os.getpid()}\) is writing this run folder"):
            with locked(tmp_path / "run"):
                pass
    with locked(tmp_path / "run"):  # released when the block ends
        pass


def test_a_second_sweep_on_a_running_run_folder_exits_2_and_changes_nothing(tmp_path, capsys, monkeypatch):
    root = project(tmp_path)
    monkeypatch.chdir(root)
    cfg = _sweep_config(tmp_path, "mine")
    with locked(root / "results" / "mine"):
        before = snapshot(root)
        assert cli.main(["sweep", "--config", cfg]) == 2
        assert "is writing this run folder" in one_line_error(capsys)
        assert snapshot(root) == before


def test_a_lock_left_by_a_killed_process_is_recovered(tmp_path):
    code = ("import sys, time; from poir_mjx.folder_lock import locked\n"
            "with locked(sys.argv[1]):\n    print('held', flush=True); time.sleep(60)")  # fmt: skip
    proc = subprocess.Popen([sys.executable, "-c", code, str(tmp_path / "run")], stdout=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONPATH": str(ROOT)})  # fmt: skip
    try:
        assert proc.stdout.readline().strip() == "held"
        with pytest.raises(ConfigError, match=rf"pid {proc.pid}"):
            with locked(tmp_path / "run"):
                pass
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    assert (tmp_path / "run" / ".lock").is_file()  # the dead process's lock file is still there
    with locked(tmp_path / "run"):
        pass


def test_a_rerun_of_a_published_run_on_other_demos_says_so_in_one_line(tmp_path):
    from poir_mjx.sweep.run_folder import demo_note

    ran = {"jax": "0.7.0", "mujoco": "3.3.7"}
    root = project(tmp_path, cells={"config_hash": "x", "episodes": 10, "successes": 4, "data": {"sha256": "a711ae91"},
                                    "stack": ran})  # fmt: skip
    local, results = root / "results" / "local" / PUBLISHED, root / "results"
    note = demo_note(PUBLISHED, local, {"lift": "6e78b1ec"}, results, ran)
    assert note.count("\n") == 0 and "lift 6e78b1ec here, a711ae91 there" in note and "sampling error" in note
    assert "software" not in note
    assert demo_note(PUBLISHED, local, {"lift": "a711ae91"}, results, ran) is None  # the same data and versions
    assert demo_note("other", local, {"lift": "6e78b1ec"}, results, ran) is None  # no published run of the name
    newer = demo_note(PUBLISHED, local, {"lift": "a711ae91"}, results, {**ran, "jax": "0.11.2"})  # other versions
    assert newer.count("\n") == 0 and "the software (jax 0.11.2 here, 0.7.0 there)" in newer and "expert" not in newer
