"""`demos spread` (poir_mjx/data/spread.py): the per-dimension action spread of demo sets side by side."""

import json

import numpy as np
import pytest

from poir_mjx import cli
from poir_mjx.data.robomimic import write_robomimic
from poir_mjx.data.spread import action_spread
from tests.helpers import ENV_ARGS, make_demo


def test_action_spread_of_known_actions():
    a = np.zeros((10, 7))
    a[:, 5] = [0.3, -0.3] * 5  # rz only: std 0.3
    a[:, 6] = [-1, -1, 1, 1, -1, 1, -1, -1, 1, 1]  # demo 0 (6 steps): close, open, close; demo 1 (4 steps): one close
    s = action_spread(a, np.array([6, 4]))
    assert s["std"]["rz"] == pytest.approx(0.3) and s["std"]["rx"] == 0 and s["std"]["dx"] == 0
    assert s["rotation_std"] == pytest.approx(0.3 / np.sqrt(3))
    assert (s["length_mean"], s["length_min"], s["length_max"], s["length_std"]) == (5, 4, 6, 1)
    assert s["gripper_close"] == 0.5 and s["gripper_at_bounds"] == 1.0
    assert s["gripper_switches_per_demo"] == 2 and s["demos_with_regrasp"] == 1  # the switch between demos not counted


def test_the_command_puts_two_demo_sets_side_by_side(tmp_path, capsys):
    a = write_robomimic(tmp_path / "a.hdf5", [make_demo(5, 0), make_demo(4, 1)], ENV_ARGS)
    gen = json.dumps({"expert": "e", "demo_style": "human_like"})
    b = write_robomimic(tmp_path / "b.hdf5", [make_demo(7, 2)], ENV_ARGS, extra_attrs={"poir_mjx_generator": gen})
    out = tmp_path / "spread.md"
    assert cli.main(["demos", "spread", "--data", str(a), str(b), "--out", str(out)]) == 0
    table = out.read_text()
    assert "| statistic | a.hdf5 (lift, file) | b.hdf5 (lift, human_like) |" in table
    assert "| length min-max | 4-5 | 7-7 |" in table and "| std rz |" in table and "Command: `" in table
    rows = json.loads(out.with_suffix(".json").read_text())
    assert [r["demos"] for r in rows] == [2, 1] and rows[1]["style"] == "human_like"
    assert "| std gripper |" in capsys.readouterr().out
