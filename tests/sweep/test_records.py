"""The cell records' schema, checked on every read through the one reader (poir_mjx/sweep/records.py)."""

import json

import pytest

from poir_mjx import cli
from poir_mjx.core.config import ConfigError
from poir_mjx.sweep.config import SweepConfig
from poir_mjx.sweep.plan import SweepPlan
from tests.helpers import one_line_error

CFG = SweepConfig(name="x", episodes=10, sigma_init=(0.02, 0.2))


def _plan(tmp_path):
    return SweepPlan.build(CFG, tmp_path / "x", {"lift": "d" * 16})


def _good(cell) -> dict:
    return {"config_hash": cell.config_hash, "task": "lift", "method": "EBC", "seed": 0, "episodes": 10,
            "sigma_init": cell.sigma_init, "sigma_action": 0.0, "successes": 4, "diverged": 1, "data": {"sha256": "d" * 16}}  # fmt: skip


BAD = [  # (what is changed, the error), each a hand edit the tables must never use
    ({"successes": 11}, r"field 'successes' \(11\) exceeds field 'episodes' \(10\)"),
    ({"diverged": 12}, r"field 'diverged' \(12\) exceeds field 'episodes' \(10\)"),
    ({"episodes": 7, "successes": 3}, r"field 'episodes' is 7, the config's cell has 10"),
    ({"episodes": 0, "successes": 0}, r"field 'episodes' \(0\) must be at least 1"),
    ({"episodes": 10**30}, r"field 'episodes' \(1000000000000000000000000000000\) exceeds 1000000000"),
    ({"successes": 1e30}, r"field 'successes' must be a count"),
    ({"successes": -1}, r"field 'successes' must be a count"),
    ({"successes": True}, r"field 'successes' must be a count"),
    ({"diverged": None}, r"field 'diverged' must be a count"),
    ({"sigma_init": 0.4}, r"field 'sigma_init' is 0.4, the config's cell has 0.02"),
    ({"method": "POIR-DRIL"}, r"field 'method' is 'POIR-DRIL', the config's cell has 'EBC'"),
    ({"seed": 1}, r"field 'seed' is 1, the config's cell has 0"),
]


@pytest.mark.parametrize("change, match", BAD)
def test_a_hand_edited_record_is_refused_naming_file_and_field(tmp_path, change, match):
    cell = _plan(tmp_path).cell("lift", "EBC", 0.02, 0.0, 0)
    cell.path.parent.mkdir(parents=True)
    cell.path.write_text(json.dumps({**_good(cell), **change}))
    with pytest.raises(ConfigError, match=rf"si=0.02_sa=0_seed=0.json: {match}"):
        cell.record()


def test_a_good_record_reads_and_a_stale_one_is_recomputed(tmp_path):
    cell = _plan(tmp_path).cell("lift", "EBC", 0.02, 0.0, 0)
    cell.path.parent.mkdir(parents=True)
    cell.path.write_text(json.dumps(_good(cell)))
    assert cell.record()["successes"] == 4
    cell.path.write_text(json.dumps({**_good(cell), "config_hash": "other", "successes": 99}))
    assert cell.record() is None


@pytest.mark.parametrize("text, match", [
    ('{"config_hash": "h", "successes": 1, "successes": 9}', "field 'successes' is given more than once"),
    ("[" * 100000 + "]" * 100000, "not a readable cell record"),
    (b'{"task": "\xff"}', "not a readable cell record"),
    ('{"episodes": 1' + "0" * 5000 + "}", "not a readable cell record"),
    ("[1, 2]", "not a cell record"),
])  # fmt: skip
def test_an_unreadable_record_is_one_line(tmp_path, text, match):
    cell = _plan(tmp_path).cell("lift", "EBC", 0.2, 0.0, 0)
    cell.path.parent.mkdir(parents=True)
    (cell.path.write_bytes if isinstance(text, bytes) else cell.path.write_text)(text)
    with pytest.raises(ConfigError, match=match):
        cell.record()


def test_compare_refuses_a_bad_record_naming_it(tmp_path, capsys):
    run = tmp_path / "x"
    (run / "cells" / "lift" / "EBC").mkdir(parents=True)
    (run / "config.json").write_text(json.dumps({"name": "x", "episodes": 10, "sigma_init": [0.02, 0.2], "ranking": "balanced"}))
    cell = _plan(tmp_path).cell("lift", "EBC", 0.02, 0.0, 0)
    cell.path.write_text(json.dumps({**_good(cell), "successes": 30}))
    assert cli.main(["compare", str(run)]) == 2
    assert "si=0.02_sa=0_seed=0.json: field 'successes' (30) exceeds field 'episodes' (10)" in one_line_error(capsys)
    (run / "config.json").write_text("[1, 2]")
    assert cli.main(["compare", str(run)]) == 2
    assert "config.json: not a sweep config (expected a JSON object, got list)" in one_line_error(capsys)
