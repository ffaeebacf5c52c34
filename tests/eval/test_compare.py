"""`compare`: one table across sweep runs (ablations), read from their cell records."""

import json

import pytest

from poir_mjx import cli
from poir_mjx.eval.compare import compare


def _run(root, name, overrides, cells, demo_files=None):
    run = root / name
    (run / "cells").mkdir(parents=True)
    (run / "config.json").write_text(json.dumps({"name": name, "overrides": overrides, "demo_files": demo_files or {}}))
    for j, (method, si, k, n) in enumerate(cells):
        rec = {"task": "lift", "method": method, "sigma_init": si, "sigma_action": 0.0, "successes": k, "episodes": n}
        (run / "cells" / f"{j}.json").write_text(json.dumps(rec))
    return run


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
    (tmp_path / "config.json").write_text("{}")
    with pytest.raises(Exception, match="no cell records"):
        compare([tmp_path])
