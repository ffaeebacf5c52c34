"""``bench physics`` (make bench-env): presets side by side, rows written as measured (no physics compiled here)."""

import json

import pytest

from poir_mjx.bench import physics as bench
from poir_mjx.bench.options import BenchPhysics


def fake_timing(ms):
    def time_substep(task, presets, batch, steps, rounds):
        return [{"task": task, "physics": p, "batch": batch, "steps": steps, "rounds": rounds, "substeps": 25,
                 "ms_per_control_step": 25 * ms[p], "ms_per_substep": ms[p], "median_ms_per_substep": ms[p],
                 "compile_and_first_step_s": 1.0, "load_average_1min": 2.0, "diverged": 0} for p in presets]  # fmt: skip

    return time_substep


def test_presets_side_by_side_with_speed_up_and_fidelity(tmp_path, monkeypatch):
    monkeypatch.setattr(bench, "time_substep", fake_timing({"reference": 100.0, "fast": 20.0}))
    monkeypatch.setattr(bench, "has_robosuite", lambda: True)
    monkeypatch.setattr(bench, "robosuite_replay", lambda task: None)
    monkeypatch.setattr(bench, "fidelity", lambda task, physics, ref: {
        "task": task, "physics": physics, "steps": 90, "max_eef_error_mm": 0.28, "max_object_error_mm": 0.75,
        "object_lifted_mm": 200.0, "robosuite_object_lifted_mm": 201.0, "success_agrees_every_step": True,
        "diverged": False})  # fmt: skip
    assert bench.run(BenchPhysics(out=tmp_path, tasks=("lift",), batch_sizes=(1, 16))) == 0
    res = json.loads((tmp_path / "physics.json").read_text())
    assert [(r["physics"], r["batch"]) for r in res["timing"]] == [("reference", 1), ("fast", 1), ("reference", 16), ("fast", 16)]
    md = (tmp_path / "physics.md").read_text()
    assert "| lift | fast | 16 | 20.00 (20.00) | 500.0 | 5.00x | 1 | 2.0 |" in md
    assert "| lift | reference | 0.28 | 0.75 | 200 / 201 | yes |" in md
    assert "iterations=10" in md and "cores" in md  # the presets and the machine are named


def test_rows_measured_before_an_interruption_are_kept(tmp_path, monkeypatch):
    timing = fake_timing({"reference": 100.0, "fast": 20.0})

    def interrupted(task, presets, batch, steps, rounds):
        if batch == 16:
            raise KeyboardInterrupt
        return timing(task, presets, batch, steps, rounds)

    monkeypatch.setattr(bench, "time_substep", interrupted)
    with pytest.raises(KeyboardInterrupt):
        bench.run(BenchPhysics(out=tmp_path, tasks=("lift",), batch_sizes=(1, 16), fidelity=False))
    assert len(json.loads((tmp_path / "physics.json").read_text())["timing"]) == 2
