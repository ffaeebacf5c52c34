"""Hostile inputs, tried as a new user would (issue 43): each probe is one command line run in-process against a
project folder holding a published run, and must end in exit status 2 with one line naming the file, flag or field,
leaving every file under results/, checkpoints/ and data/ as it was (hashed before and after).

No probe trains or compiles an MJX program: each is refused before any work."""

import json
import os
from pathlib import Path

import h5py
import numpy as np
import pytest
from flax import serialization

from poir_mjx import cli
from poir_mjx.core import checkpoint
from poir_mjx.data.robomimic import write_robomimic
from poir_mjx.folder_lock import locked
from poir_mjx.sweep.artifacts import cell_hash
from poir_mjx.sweep.config import SweepConfig
from tests.helpers import ENV_ARGS, PUBLISHED, make_demo, one_line_error, project, snapshot

DIGEST = "d" * 16


def _run(root: Path, name: str, record: dict | bytes | str, config: dict | bytes | None = None) -> None:
    """results/<name>/ with a config and one cell record of lift/EBC at sigma_init 0.02 (made for `compare`)."""
    run = root / "results" / name
    cell = run / "cells" / "lift" / "EBC" / "si=0.02_sa=0_seed=0.json"
    cell.parent.mkdir(parents=True)
    cfg = config if config is not None else {"name": name, "methods": ["EBC"], "episodes": 10}
    (run / "config.json").write_bytes(cfg if isinstance(cfg, bytes) else json.dumps(cfg).encode())
    if isinstance(record, dict):
        record = json.dumps({**GOOD, **record})
    (cell.write_bytes if isinstance(record, bytes) else cell.write_text)(record)


GOOD = {"config_hash": cell_hash(SweepConfig(name="x", methods=("EBC",), episodes=10), "lift", "EBC", DIGEST),
        "task": "lift", "method": "EBC", "seed": 0, "sigma_init": 0.02, "sigma_action": 0.0, "episodes": 10,
        "successes": 4, "diverged": 0, "data": {"sha256": DIGEST}}  # fmt: skip

BAD_RECORDS = {  # run name -> the record's text or changed fields
    "rec-successes": {"successes": 11},
    "rec-diverged": {"diverged": 11},
    "rec-episodes": {"episodes": 7, "successes": 3},
    "rec-zero": {"episodes": 0, "successes": 0},
    "rec-float": {"successes": 1e30},
    "rec-huge": {"episodes": 10**30},
    "rec-negative": {"diverged": -2},
    "rec-bool": {"successes": True},
    "rec-dup": '{"config_hash": "h", "successes": 1, "successes": 2}',
    "rec-utf8": b'{"task": "\xff\xfe"}',
    "rec-deep": "[" * 50000 + "]" * 50000,
    "rec-digits": '{"episodes": 1' + "0" * 5000 + "}",
    "rec-list": "[1, 2, 3]",
}
BAD_RUN_CONFIGS = {"cfg-list": b"[1, 2]", "cfg-utf8": b'{"name": "\xff"}', "cfg-deep": b"[" * 50000 + b"]" * 50000}


def _hdf5(root: Path) -> dict[str, Path]:
    """Damaged robomimic files, one flaw each."""
    out = {}

    def make(name, edit):
        path = write_robomimic(root / "hostile" / f"{name}.hdf5", [make_demo(5, 0), make_demo(4, 1)], ENV_ARGS)
        with h5py.File(path, "r+") as f:
            edit(f)
        out[name] = path

    def replace(f, where, **kw):
        group, _, key = where.rpartition("/")
        del f[group][key]
        if "link" in kw:
            f[group][key] = kw["link"]
        elif "group" in kw:
            f[group].create_group(key)
        else:
            f[group].create_dataset(key, data=kw["data"])

    make("num-samples-text", lambda f: f["data/demo_0"].attrs.__setitem__("num_samples", "five"))
    make("num-samples-nan", lambda f: f["data/demo_0"].attrs.__setitem__("num_samples", np.nan))
    make("num-samples-wrong", lambda f: f["data/demo_0"].attrs.__setitem__("num_samples", 7))
    make("dangling-link", lambda f: replace(f, "data/demo_0/obs/object", link=h5py.ExternalLink("gone.hdf5", "/x")))
    make("key-is-group", lambda f: replace(f, "data/demo_0/obs/object", group=True))
    make("complex-actions", lambda f: replace(f, "data/demo_0/actions", data=np.ones((5, 7)) * (1 + 2j)))
    make("float32-overflow", lambda f: f["data/demo_1/next_obs/object"].__setitem__((1, 3), 1e39))
    make("nan", lambda f: f["data/demo_1/actions"].__setitem__((0, 0), np.nan))
    make("text-actions", lambda f: replace(f, "data/demo_0/actions", data=np.array([b"a"] * 5)))
    make("obs-is-dataset", lambda f: replace(f, "data/demo_0/obs", data=np.zeros((5, 19))))
    make("env-name", lambda f: f["data"].attrs.__setitem__("env_args", json.dumps({"env_name": "Door"})))
    make("no-demos", lambda f: [f["data"].__delitem__(k) for k in list(f["data"].keys())])
    make("few-samples", lambda f: None)  # 9 transitions: fewer than the preset's batch
    (root / "hostile" / "not-hdf5.hdf5").write_text("hello")
    out["not-hdf5"] = root / "hostile" / "not-hdf5.hdf5"
    return out


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    root = project(tmp_path_factory.mktemp("project"))
    os.mkfifo(root / "FIFO")
    (root / "LINK").symlink_to(root / "results" / PUBLISHED / "lift.md")
    (root / "afile").write_text("a regular file")
    (root / "results" / "alias").symlink_to(root / "results" / PUBLISHED)
    linked = root / "results" / "linked" / "cells" / "lift"
    linked.mkdir(parents=True)
    (linked / "EBC").symlink_to(root / "results" / PUBLISHED / "cells" / "lift" / "EBC")
    (root / "results" / "dirmd" / "lift.md").mkdir(parents=True)
    fifo_cell = root / "results" / "fifocell" / "cells" / "lift" / "EBC"
    fifo_cell.mkdir(parents=True)
    os.mkfifo(fifo_cell / "si=0.02_sa=0_seed=0.json")
    for name, rec in BAD_RECORDS.items():
        _run(root, name, rec)
    for name, cfg in BAD_RUN_CONFIGS.items():
        _run(root, name, {}, cfg)
    (root / "record.json").write_text(json.dumps(GOOD))
    (root / "old.ckpt").write_bytes(serialization.msgpack_serialize({"format": checkpoint.FORMAT, "config": "{}"}))
    (root / "junk.ckpt").write_bytes(b"\x85" + os.urandom(64))
    (root / "hostile").mkdir()
    _hdf5(root)
    return root


def _config(root: Path, name: str, text: str | bytes) -> str:
    path = root / "hostile" / f"{name}.json"
    (path.write_bytes if isinstance(text, bytes) else path.write_text)(text)
    return str(path)


def sweep(**fields):
    """A sweep config's text: lift, EBC, the given fields (name 'mine' unless given)."""
    return json.dumps({"name": "mine", "tasks": ["lift"], "methods": ["EBC"], **fields})


def demo_sweep(flaw: str):
    return lambda root: sweep(name=f"demo-{flaw}", demo_files={"lift": str(root / "hostile" / f"{flaw}.hdf5")})


# (id, argv (strings; "{cfg}" is the probe's config file, "{root}" the project), the config's text or a function of
# the project giving it, what the line must contain)
PROBES = [
    # 1. outputs: nothing published is overwritten, no special file, no symlink out, no '..'
    ("eval-out-dev-full", ["eval", "--ckpt", "x.ckpt", "--out", "/dev/full"], None, "--out: /dev/full is a device"),
    ("eval-out-fifo", ["eval", "--ckpt", "x.ckpt", "--out", "FIFO"], None, "--out: FIFO is a fifo"),
    ("eval-out-symlink", ["eval", "--ckpt", "x.ckpt", "--out", "LINK"], None, "--out: LINK is a symbolic link"),
    ("eval-out-published", ["eval", "--ckpt", "x.ckpt", "--out", "results/pub/t.md"], None, "in the published run"),
    ("eval-out-dir", ["eval", "--ckpt", "x.ckpt", "--out", "results"], None, "--out: results is a directory"),
    ("eval-out-under-file", ["eval", "--ckpt", "x.ckpt", "--out", "afile/t.md"], None, "afile is a file, expected a folder"),
    ("compare-out-fifo", ["compare", "results/pub", "--out", "FIFO"], None, "--out: FIFO is a fifo"),
    ("compare-out-published", ["compare", "results/pub", "--out", "results/pub/lift.md"], None, "published run"),
    ("compare-out-via-alias", ["compare", "results/pub", "--out", "results/alias/x.md"], None, "published run"),
    ("report-out-fifo", ["report", "--out", "FIFO"], None, "--out: FIFO is a fifo"),
    ("report-out-dev-null", ["report", "--out", "/dev/null"], None, "--out: /dev/null is a device"),
    ("report-out-dir", ["report", "--out", "results"], None, "--out: results is a directory"),
    ("report-into-published", ["report", "--results", "results/pub"], None, "--results: results/pub/README.md"),
    ("bench-name-dotdot", ["bench", "env", "--name", "../pub/lift"], None, "--name: must be a plain file name"),
    ("bench-name-absolute", ["bench", "env", "--name", "/tmp/x"], None, "--name: must be a plain file name"),
    ("bench-name-hidden", ["bench", "env", "--name", ".x"], None, "--name: must be a plain file name"),
    ("bench-env-out-published", ["bench", "env", "--out", "results/pub"], None, "--out: results/pub is in the published"),
    ("bench-planner-out-published", ["bench", "planner", "--out", "results/pub/x"], None, "published run"),
    ("bench-e2e-out-device", ["bench", "e2e", "--out", "/dev/null"], None, "--out: /dev/null is a device"),
    ("bench-robosuite-out-file", ["bench", "robosuite", "--out", "afile"], None, "--out: afile is a file"),
    ("demos-out-published", ["demos", "generate", "--out", "results/pub/cells"], None, "--out: results/pub/cells"),
    ("demos-out-device", ["demos", "generate", "--out", "/dev/full"], None, "--out: /dev/full is a device"),
    ("demos-success-out-published", ["demos", "success", "--out", "results/pub"], None, "published run"),
    ("gpu-check-out-published", ["gpu-check", "--dry-run", "--out", "results/pub"], None, "published run"),
    ("gpu-check-scratch-published", ["gpu-check", "--dry-run", "--scratch", "results/pub/s"], None, "--scratch"),
    ("envs-out-published", ["envs", "--out", "results/pub"], None, "--out: results/pub is in the published"),
    ("sweep-published", ["sweep", "--config", "{cfg}"], sweep(name=PUBLISHED), "(its config.json is tracked by git) is read-only"),
    ("sweep-published-replace", ["sweep", "--config", "{cfg}", "--replace-config"], sweep(name=PUBLISHED, episodes=3),
     "--replace-config included"),
    ("sweep-published-via-alias", ["sweep", "--config", "{cfg}"], sweep(name="alias"), "is read-only"),
    ("sweep-results-in-published", ["sweep", "--config", "{cfg}", "--results", "results/pub"], sweep(), "--results"),
    ("sweep-checkpoints-published", ["sweep", "--config", "{cfg}", "--checkpoints", "results/pub/ck"], sweep(),
     "--checkpoints: results/pub/ck is in the published run"),
    ("sweep-data-device", ["sweep", "--config", "{cfg}", "--data", "/dev/null"], sweep(), "--data: /dev/null"),
    ("sweep-data-file", ["sweep", "--config", "{cfg}", "--data", "afile"], sweep(), "--data: afile is a file"),
    ("sweep-symlink-out", ["sweep", "--config", "{cfg}"], sweep(name="linked"), "a symbolic link out of the run"),
    ("sweep-table-is-dir", ["sweep", "--config", "{cfg}"], sweep(name="dirmd"), "lift.md is a directory"),
    ("sweep-cell-is-fifo", ["sweep", "--config", "{cfg}"], sweep(name="fifocell"), "a fifo in the run folder"),
    ("sweep-name-dotdot", ["sweep", "--config", "{cfg}"], sweep(name="../x"), "field 'name': must be a plain"),
    # 4. cell records verified when read (compare reads them through the one reader)
    *[(f"compare-{name}", ["compare", f"results/{name}"], None, f"results/{name}/")
      for name in [*BAD_RECORDS, *BAD_RUN_CONFIGS]],  # fmt: skip
    # 5. configs: one line naming the file and field
    ("config-not-utf8", ["sweep", "--config", "{cfg}"], b'{"name": "\xff\xfe"}', "not UTF-8 text"),
    ("config-5000-digits", ["sweep", "--config", "{cfg}"], '{"name": "x", "episodes": 1' + "0" * 5000 + "}",
     "not valid JSON"),
    ("config-deep", ["sweep", "--config", "{cfg}"], "[" * 50000 + "]" * 50000, "not valid JSON (nested too deeply)"),
    ("config-list", ["sweep", "--config", "{cfg}"], "[1, 2]", "expected a JSON object"),
    ("config-seed-2-64", ["sweep", "--config", "{cfg}"], sweep(seeds=[2**64]), "field 'seeds': must be in [0, 4294967295]"),
    ("config-seed-negative", ["sweep", "--config", "{cfg}"], sweep(seeds=[-1]), "field 'seeds': must be >= 0"),
    ("config-episodes-float", ["sweep", "--config", "{cfg}"], sweep(episodes=1e10), "field 'episodes': expected an integer"),
    ("config-episodes-huge", ["sweep", "--config", "{cfg}"], sweep(episodes=10**10), "field 'episodes': must be in [1, 1000000]"),
    ("config-episodes-nan", ["sweep", "--config", "{cfg}"], '{"name": "x", "episodes": NaN}', "field 'episodes'"),
    ("config-sigma-1e300", ["sweep", "--config", "{cfg}"], sweep(sigma_init=[1e300]), "field 'sigma_init': must be in"),
    ("config-sigma-inf", ["sweep", "--config", "{cfg}"], '{"name": "x", "sigma_init": [Infinity]}', "must be finite"),
    ("config-sigma-collide", ["sweep", "--config", "{cfg}"], sweep(sigma_init=[0.1, 0.10000001]), "share one cell file"),
    ("config-sigma-action-negative", ["sweep", "--config", "{cfg}"], sweep(sigma_action=[-0.1]), "field 'sigma_action'"),
    ("config-max-steps-zero", ["sweep", "--config", "{cfg}"], sweep(max_steps=0), "field 'max_steps': must be positive"),
    ("config-num-demos-huge", ["sweep", "--config", "{cfg}"], sweep(num_demos=10**7), "field 'num_demos': must be in"),
    ("config-workers-huge", ["sweep", "--config", "{cfg}"], sweep(workers=5000), "field 'workers': must be in"),
    ("config-demo-batch-zero", ["sweep", "--config", "{cfg}"], sweep(demo_batch=0), "field 'demo_batch'"),
    ("config-unknown-field", ["sweep", "--config", "{cfg}"], sweep(epochz=3), "unknown field(s) ['epochz']"),
    ("config-duplicate-key", ["sweep", "--config", "{cfg}"], '{"name": "x", "name": "y"}', "field 'name' is given more"),
    ("config-override-lr-text", ["sweep", "--config", "{cfg}"], sweep(overrides={"train.learning_rate": "big"}),
     "train.learning_rate"),
    ("config-override-int-huge", ["sweep", "--config", "{cfg}"], sweep(overrides={"train.epochs": 10**12}),
     "train.epochs"),
    ("config-demo-file-dir", ["sweep", "--config", "{cfg}"], sweep(demo_files={"lift": "results"}), "is a directory"),
    # 5. flags: one line naming the flag
    ("eval-seed-negative", ["eval", "--ckpt", "x.ckpt", "--seed", "-5"], None, "--seed: must be >= 0"),
    ("eval-seed-2-64", ["eval", "--ckpt", "x.ckpt", "--seed", str(2**64)], None, "--seed: must be in"),
    ("eval-episodes-huge", ["eval", "--ckpt", "x.ckpt", "--episodes", str(10**10)], None, "--episodes: must be in"),
    ("eval-sigma-1e300", ["eval", "--ckpt", "x.ckpt", "--sigma-init", "1e300"], None, "--sigma-init: must be in"),
    ("eval-sigma-nan", ["eval", "--ckpt", "x.ckpt", "--sigma-init", "nan"], None, "--sigma-init: must be finite"),
    ("eval-sigma-twice", ["eval", "--ckpt", "x.ckpt", "--sigma-init", "0.1", "0.1"], None, "--sigma-init: lists 0.1"),
    ("eval-workers-zero", ["eval", "--ckpt", "x.ckpt", "--workers", "0"], None, "--workers: must be positive"),
    ("demos-seed-negative", ["demos", "generate", "--seed", "-5"], None, "--seed: must be >= 0"),
    ("demos-num-zero", ["demos", "generate", "--num", "0"], None, "--num: must be positive"),
    ("demos-sigma-inf", ["demos", "generate", "--sigma-init", "inf"], None, "--sigma-init: must be finite"),
    ("demos-success-episodes-zero", ["demos", "success", "--episodes", "0"], None, "--episodes: must be positive"),
    ("bench-batch-zero", ["bench", "env", "--batch-sizes", "0"], None, "--batch-sizes: must be positive"),
    ("bench-planner-calls-negative", ["bench", "planner", "--calls", "-1"], None, "--calls: must be"),
    ("gpu-check-only-without-gpu", ["gpu-check", "--only", "env", "--out", "gpu"], None, "a GPU was requested"),
    # 7. checkpoints verified when read, and the advice fits the file
    ("eval-ckpt-cell-record", ["eval", "--ckpt", "record.json"], None, "record.json: not a poir-mjx checkpoint"),
    ("eval-ckpt-old-format", ["eval", "--ckpt", "old.ckpt"], None, "old.ckpt: written before checkpoints carried"),
    ("eval-ckpt-junk", ["eval", "--ckpt", "junk.ckpt"], None, "junk.ckpt: not a poir-mjx checkpoint"),
    ("eval-ckpt-dir", ["eval", "--ckpt", "results"], None, "results: is a directory"),
    ("eval-ckpt-missing", ["eval", "--ckpt", "none.ckpt"], None, "none.ckpt: no such checkpoint file"),
    # 3 and 5. expert data checked before training (the sweep reads it, then stops with one line)
    *[(f"hdf5-{flaw}", ["sweep", "--config", "{cfg}"], demo_sweep(flaw), f"{flaw}.hdf5")
      for flaw in ("num-samples-text", "num-samples-nan", "num-samples-wrong", "dangling-link", "key-is-group",
                   "complex-actions", "float32-overflow", "nan", "text-actions", "obs-is-dataset", "env-name",
                   "no-demos", "not-hdf5")],  # fmt: skip
]


def test_there_are_at_least_60_probes():
    assert len(PROBES) >= 60 and len({p[0] for p in PROBES}) == len(PROBES)


@pytest.mark.parametrize("argv, config, expect", [p[1:] for p in PROBES], ids=[p[0] for p in PROBES])
def test_probe(root, monkeypatch, capsys, argv, config, expect):
    monkeypatch.chdir(root)
    if config is not None:
        cfg = _config(root, "probe", config(root) if callable(config) else config)
        argv = [a.replace("{cfg}", cfg) for a in argv]
    before = snapshot(root)
    assert cli.main(argv) == 2
    line = one_line_error(capsys)
    assert expect in line, line
    assert snapshot(root) == before


def test_a_second_sweep_on_a_locked_run_folder(root, monkeypatch, capsys):
    monkeypatch.chdir(root)
    cfg = _config(root, "locked", sweep(name="busy"))
    with locked(root / "results" / "busy"):
        before = snapshot(root)
        assert cli.main(["sweep", "--config", cfg]) == 2
        assert "results/busy: another process" in one_line_error(capsys)
        assert snapshot(root) == before


def test_fewer_demos_than_the_batch_stops_before_training(root, monkeypatch, capsys):
    monkeypatch.chdir(root)
    before = snapshot(root)
    assert cli.main(["sweep", "--config", _config(root, "few", demo_sweep("few-samples")(root))]) == 2
    assert "few-samples.hdf5: 9 expert transitions, fewer than EBC's train.batch_size 256" in one_line_error(capsys)
    assert snapshot(root) == before


def test_a_full_disk_is_one_line(root, monkeypatch, capsys):
    import errno

    from poir_mjx.sweep import index

    def full(path, text):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.chdir(root)
    monkeypatch.setattr(index, "atomic_write_text", full)
    before = snapshot(root)
    assert cli.main(["report", "--out", "page.md"]) == 2
    assert one_line_error(capsys).startswith("page.md: No space left on device")
    assert snapshot(root) == before
