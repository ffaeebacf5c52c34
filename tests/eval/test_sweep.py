"""A tiny end-to-end sweep on real physics: demos, training, evaluation, tables, resume, eval CLI."""

import json

import pytest

from poir_mjx import cli
from poir_mjx.eval import sweep as sw

CFG = {
    "name": "tiny",
    "preset": "cpu-small",
    "tasks": ["lift"],
    "methods": ["EBC"],
    "sigma_init": [0.02, 0.3],
    "sigma_action": [0.0],
    "seeds": [0, 1],
    "episodes": 2,
    "max_steps": 4,
    "num_demos": 6,
    "epochs": 1,
}


@pytest.fixture(scope="module")
def dirs(tmp_path_factory):
    root = tmp_path_factory.mktemp("sweep")
    cfg_path = root / "tiny.json"
    cfg_path.write_text(json.dumps(CFG))
    return root, cfg_path


def run(root, cfg_path, results="results"):
    cfg = sw.load_sweep_config(cfg_path)
    return sw.run_sweep(cfg, root / results, root / "data", root / "ckpt", progress=False)


@pytest.mark.slow
def test_interrupted_sweep_resumes_to_the_same_tables(dirs, monkeypatch):
    root, cfg_path = dirs
    full = run(root, cfg_path, "uninterrupted")
    for f in ("lift.md", "lift.csv", "lift.png", "summary.md"):
        assert (full / f).exists(), f
    rec = json.loads((full / "cells/lift/EBC/si=0.3_sa=0_seed=1.json").read_text())
    assert rec["episodes"] == 2 and 0 <= rec["successes"] <= 2 and rec["data"]["source"] == "scripted expert"
    assert "robosuite" in rec["data"]["simulator"] and len(rec["wilson95"]) == 2
    assert "scripted expert" in (full / "lift.md").read_text()

    # Kill the sweep after its first batch (seed 0): seed 0's cells exist, seed 1's do not.
    real = sw.run_batch
    calls = {"n": 0}

    def dying(*a, **k):
        calls["n"] += 1
        if calls["n"] == 2:
            raise KeyboardInterrupt
        return real(*a, **k)

    monkeypatch.setattr(sw, "run_batch", dying)
    with pytest.raises(KeyboardInterrupt):
        run(root, cfg_path)
    out = root / "results" / "tiny"
    assert (out / "cells/lift/EBC/si=0.02_sa=0_seed=0.json").exists()
    assert not (out / "cells/lift/EBC/si=0.02_sa=0_seed=1.json").exists()
    assert not list(out.rglob("*.tmp"))
    done = (out / "cells/lift/EBC/si=0.02_sa=0_seed=0.json").stat().st_mtime_ns

    monkeypatch.setattr(sw, "run_batch", real)
    run(root, cfg_path)  # the same command again
    assert (out / "cells/lift/EBC/si=0.02_sa=0_seed=0.json").stat().st_mtime_ns == done  # not recomputed
    assert (out / "lift.csv").read_text() == (full / "lift.csv").read_text()
    assert (out / "lift.md").read_text() == (full / "lift.md").read_text()


@pytest.mark.slow
def test_eval_cli_on_the_sweeps_checkpoint(dirs, capsys):
    root, _ = dirs
    ckpt = next((root / "ckpt" / "lift").glob("policy-seed0-*.ckpt"))
    rc = cli.main(["eval", "--ckpt", str(ckpt), "--sigma-init", "0.02", "0.3", "--episodes", "2", "--max-steps", "4"])
    out = capsys.readouterr().out
    assert rc == 0 and "| 0.3 | 0 |" in out and "EBC" in out and "scripted expert" in out


def test_bad_input_exits_nonzero_and_touches_nothing(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**CFG, "methods": ["EBC", "GAIL"]}))
    rc = cli.main(["sweep", "--config", str(bad), "--results", str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert rc == 2 and "field 'methods': unknown method 'GAIL'" in err and err.count("\n") == 1
    assert not (tmp_path / "r").exists()
    rc = cli.main(["eval", "--ckpt", str(tmp_path / "none.ckpt")])
    assert rc == 2 and "no such checkpoint" in capsys.readouterr().err
