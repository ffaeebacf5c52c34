"""`compare`: one table across sweep runs (ablations), read from their cell records."""

import json

import pytest

from poir_mjx import cli
from poir_mjx.sweep.artifacts import cell_hash
from poir_mjx.sweep.compare import compare
from poir_mjx.sweep.config import SweepConfig


def _run(root, name, overrides, cells, demo_files=None, stale=()):
    """A run folder whose cells carry the config hash its config.json gives (those in `stale`: another one)."""
    run = root / name
    (run / "cells").mkdir(parents=True)
    cfg = {"name": name, "overrides": overrides, "demo_files": demo_files or {}}
    (run / "config.json").write_text(json.dumps(cfg))
    sweep = SweepConfig(**cfg)
    for j, (method, si, k, n) in enumerate(cells):
        chash = "old" if j in stale else cell_hash(sweep, "lift", method, "abc")
        rec = {"task": "lift", "method": method, "sigma_init": si, "sigma_action": 0.0, "successes": k, "episodes": n,
               "config_hash": chash, "data": {"sha256": "abc"}}  # fmt: skip
        (run / "cells" / f"{j}.json").write_text(json.dumps(rec))
    return run


def test_stale_cells_never_enter_the_table(tmp_path, capsys):
    run = _run(tmp_path, "base", {}, [("EBC", 0.02, 9, 10), ("EBC", 0.3, 1, 10)], stale=(1,))
    lines = compare([run]).splitlines()
    assert lines[0] == "| run | overrides | method | lift σ_init 0.02 |" and "| base | - | EBC | 9/10" in lines[2]
    assert "1 stale cell record(s) left out" in capsys.readouterr().out
    only_stale = _run(tmp_path, "old", {}, [("EBC", 0.3, 1, 10)], stale=(0,))
    with pytest.raises(Exception, match="1 stale cell"):
        compare([only_stale])


def test_rows_per_run_and_method_with_overrides(tmp_path):
    a = _run(tmp_path, "base", {}, [("EBC", 0.02, 9, 10), ("POIR-DRIL", 0.02, 7, 10), ("POIR-DRIL", 0.3, 2, 10)])
    b = _run(tmp_path, "sigma", {"planner.sigma": 0.1}, [("POIR-DRIL", 0.3, 5, 10)])
    c = _run(tmp_path, "wide", {}, [("EBC", 0.3, 8, 10)], demo_files={"lift": "data/wide/lift.hdf5"})
    text = compare([a, b, c])
    lines = text.splitlines()
    assert lines[0] == "| run | overrides | method | lift σ_init 0.02 | lift σ_init 0.3 |"
    assert "| base | - | POIR-DRIL | 7/10 = 0.70 [0.40, 0.89] | 2/10 = 0.20 [0.06, 0.51] |" in lines
    assert "| sigma | planner.sigma=0.1 | POIR-DRIL | - | 5/10 = 0.50 [0.24, 0.76] |" in lines
    # other demonstrations are a change of the run too: the row names the file
    assert "| wide | demo_files.lift=data/wide/lift.hdf5 | EBC | - | 8/10 = 0.80 [0.49, 0.94] |" in lines


def test_a_folder_without_cells_is_one_line_and_exit_2(tmp_path, capsys):
    rc = cli.main(["compare", str(tmp_path)])
    err = capsys.readouterr().err
    assert rc == 2 and "config.json: no such file" in err and err.count("\n") == 1
    (tmp_path / "config.json").write_text('{"name": "x"}')
    with pytest.raises(Exception, match="no cell records"):
        compare([tmp_path])
