"""The prepared GPU run (poir_mjx/gpucheck): deadlines, the one-line refusals, and the dry run of every stage."""

import json
import sys
import time

import pytest

from poir_mjx import cli
from poir_mjx.gpucheck import preflight, runner
from poir_mjx.gpucheck.sizes import STAGES
from poir_mjx.optional import has_robosuite


def test_a_stage_past_its_deadline_is_stopped_with_its_children(tmp_path):
    flag = tmp_path / "grandchild-alive"
    code = (f"import subprocess, sys, time; subprocess.Popen([sys.executable, '-c', "
            f"'import time, pathlib; time.sleep(3); pathlib.Path(r\"{flag}\").touch()']); time.sleep(30)")
    t0 = time.monotonic()
    status, secs = runner.run_limited([sys.executable, "-c", code], 1.0)
    assert status == "stopped at its deadline (1 s)" and secs < 10 and time.monotonic() - t0 < 10
    time.sleep(4)
    assert not flag.exists()  # the whole process group went
    assert runner.run_limited([sys.executable, "-c", "raise SystemExit(3)"], 10)[0] == "failed (exit status 3)"


def test_without_a_gpu_it_is_one_line_and_exit_2(tmp_path, capsys):
    assert cli.main(["gpu-check", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "a GPU was requested but jax" in err and err.count("\n") == 1


def test_preflight_names_what_is_missing(monkeypatch, capsys):
    monkeypatch.setattr(preflight, "NEEDED", ("json", "no_such_module_xyz"))
    assert preflight.main() == 2
    err = capsys.readouterr().err
    assert "missing Python packages no_such_module_xyz;" in err and err.count("\n") == 1


@pytest.mark.slow
@pytest.mark.current_stack
@pytest.mark.skipif(has_robosuite(), reason="make test-current's: the GPU machine's software has no robosuite, and "
                    "the CPU set's own tests cover the stages' code")  # fmt: skip
def test_dry_run_runs_every_stage_and_a_rerun_skips_them(tmp_path, capsys):
    from poir_mjx.data.compact import compact
    from poir_mjx.data.robomimic import write_robomimic
    from tests.helpers import ENV_ARGS, make_demo

    out, scratch, demos = tmp_path / "gpu", tmp_path / "scratch", tmp_path / "demos"
    # Lift demos carried from a CPU (compact copies, as make gpu-carry makes them): e2e, cell and sweep train on them
    compact(write_robomimic(tmp_path / "lift.hdf5", [make_demo(100, s) for s in range(3)], ENV_ARGS), demos / "lift.hdf5")
    args = ["gpu-check", "--dry-run", "--out", str(out), "--scratch", str(scratch), "--demos", str(demos)]
    assert cli.main(args) == 0
    for stage in STAGES:
        data = json.loads((out / f"{stage}.json").read_text())
        assert data["complete"] and data["dry_run"] and data["rows"], stage
        assert data["machine"]["device"].startswith("cpu") and data["machine"]["versions"]["mujoco"]
    rows = {s: json.loads((out / f"{s}.json").read_text())["rows"] for s in STAGES}
    assert [(r["physics"], r["batch"]) for r in rows["env"]] == [("fast", 1)]
    assert all(r["control_steps_per_s"] > 0 for r in rows["env"])
    assert {r["reward"] for r in rows["planner"]} == {"dril", "l2", "morel"}
    assert all(r["matmul_flops_per_call"] > 0 and r["achieved_flop_s"] > 0 for r in rows["planner"])
    assert [r["method"] for r in rows["e2e"]] == ["EBC", "POIR-DRIL"] and rows["e2e"][0]["demos"] == "file"
    assert [(r["method"], r["episodes"]) for r in rows["cell"]] == [("EBC", 4), ("POIR-DRIL", 4)]
    assert len({r["demo_sha256"] for r in rows["cell"]}) == 1 and rows["cell"][0]["demos"] == "file"
    assert {(r["method"], r["episodes"]) for r in rows["sweep"]} == {("EBC", 2), ("POIR-DRIL", 2)}
    assert rows["expert"][0]["task"] == "lift" and rows["expert"][0]["episodes"] == 2
    assert rows["warp"][0]["not_run"].startswith("warp-lang is not installed")  # the current set has no warp-lang
    summary = (out / "summary.md").read_text()
    assert "## env: complete" in summary and "## expert: complete" in summary
    cell_compiled = json.loads((out / "cell.json").read_text())["compilations"]
    assert cell_compiled["programs"] == 0, cell_compiled  # e2e's evaluators, not compiled again (poir_mjx/cached.py)
    capsys.readouterr()
    assert cli.main(args) == 0
    assert capsys.readouterr().out.count("complete earlier") == 0  # skipped stages print nothing...
    assert "## planner: complete earlier" in (out / "summary.md").read_text()  # ...and say so in the summary


def test_e2e_bench_records_its_demos_in_mjx_without_robosuite(monkeypatch):
    from poir_mjx import optional
    from poir_mjx.bench import e2e

    monkeypatch.setattr(optional, "has_robosuite", lambda: False)
    assert e2e.default_demo_simulator() == "mjx"
    monkeypatch.setattr(optional, "has_robosuite", lambda: True)
    assert e2e.default_demo_simulator() == "robosuite"
    assert e2e.default_demo_batch() == 16  # a CPU; 256 on an accelerator


def test_benchmarks_keep_the_rows_measured_before_an_interruption(tmp_path, monkeypatch):
    from poir_mjx.bench import planner
    from poir_mjx.bench.options import BenchPlanner

    calls = {"n": 0}

    def one(preset, reward, b, calls_, states):
        calls["n"] += 1
        if calls["n"] == 2:
            raise KeyboardInterrupt  # a deadline or a kill mid-benchmark
        return {"preset": preset, "reward": reward, "batch": b, "ms_per_call": 1.0, "calls_per_s": 1.0,
                "episode_steps_per_s": 1.0, "N": 1, "H": 1, "K": 1}  # fmt: skip

    monkeypatch.setattr(planner, "bench_one", one)
    with pytest.raises(KeyboardInterrupt):
        planner.run(BenchPlanner(out=tmp_path, presets=("cpu-small",), rewards=("dril",), batch_sizes=(1, 2)))
    rows = json.loads((tmp_path / "planner.json").read_text())["rows"]
    assert len(rows) == 1 and rows[0]["batch"] == 1 and "| dril | 1 |" in (tmp_path / "planner.md").read_text()


def test_a_stage_record_counts_the_programs_it_compiles(tmp_path):
    import jax
    import jax.numpy as jnp

    from poir_mjx.gpucheck.record import Record

    rec = Record(tmp_path, "env", {}, dry_run=True)
    jax.jit(lambda x: jnp.sin(x) * 3.25 + 0.125)(jnp.arange(7.0)).block_until_ready()  # a program not seen before
    rec.add({"row": 1})
    c = json.loads((tmp_path / "env.json").read_text())["compilations"]
    assert c["programs"] >= 1 and c["backend_compile_s"] > 0 and c["trace_s"] > 0


def test_the_command_lines_stages_are_the_runners():
    """The command line's stage names and default are the runner's STAGES, in order (a stage added to one only would
    never run: the warp stage once did not)."""
    import typing

    from poir_mjx.options import GpuCheck, GpuStage

    assert typing.get_args(GpuStage) == STAGES == GpuCheck().stages

