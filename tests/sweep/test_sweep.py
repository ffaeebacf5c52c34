"""A tiny end-to-end sweep on real physics: demos, training, evaluation, tables, resume, eval CLI."""

import json
from pathlib import Path

import pytest

from poir_mjx import cli
from poir_mjx.sweep import cells
from poir_mjx.sweep import run as sw
from poir_mjx.sweep.artifacts import checkpoint_digest
from poir_mjx.optional import has_robosuite

# The CPU set records the demos in robosuite as `make sweep` does; the current set (no robosuite) in
# MJX, with the batch size of tests/data/test_mjx_demos.py so that the compiled rollout is shared.
DEMO_SIM = "robosuite" if has_robosuite() else "mjx"

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
    "overrides": {"train.epochs": 1},
    "demo_simulator": DEMO_SIM,
    "demo_batch": 2,
}


@pytest.fixture(scope="module")
def dirs(tmp_path_factory):
    root = tmp_path_factory.mktemp("sweep")
    cfg_path = root / "tiny.json"
    cfg_path.write_text(json.dumps(CFG))
    return root, cfg_path


def dies_on_call(real, n):
    """`real`, except that its n-th call raises KeyboardInterrupt (a sweep killed at that point)."""
    calls = {"n": 0}

    def wrapper(*a, **k):
        calls["n"] += 1
        if calls["n"] == n:
            raise KeyboardInterrupt
        return real(*a, **k)

    return wrapper


def run(root, cfg_path, results="results"):
    cfg = sw.load_sweep_config(cfg_path)
    return sw.run_sweep(cfg, root / results, root / "data", root / "ckpt", progress=False)


@pytest.mark.slow
@pytest.mark.current_stack
def test_interrupted_sweep_resumes_to_the_same_tables(dirs, monkeypatch):
    root, cfg_path = dirs
    full = run(root, cfg_path, "uninterrupted")
    for f in ("lift.md", "lift.csv", "lift.png", "summary.md"):
        assert (full / f).exists(), f
    rec = json.loads((full / "cells/lift/EBC/si=0.3_sa=0_seed=1.json").read_text())
    # 4 control steps cannot lift the cube: a success here would be a bug (e.g. success at reset)
    assert rec["episodes"] == 2 and rec["successes"] == 0 and rec["mean_episode_length"] == 4
    assert rec["data"]["source"] == "scripted expert" and len(rec["data"]["sha256"]) == 16
    assert rec["data"]["simulator"].startswith("robosuite" if DEMO_SIM == "robosuite" else "MJX")
    assert rec["checkpoint_sha256"] == checkpoint_digest(Path(rec["checkpoint"]))  # which agent, beyond its name
    assert len(rec["wilson95"]) == 2
    assert "scripted expert" in (full / "lift.md").read_text()
    assert "Simulator: MJX (mujoco-mjx" in (full / "lift.md").read_text() and rec["simulator"].startswith("MJX")

    # Kill the sweep after its first batch (seed 0): seed 0's cells exist, seed 1's do not.
    real = cells.run_episodes
    monkeypatch.setattr(cells, "run_episodes", dies_on_call(real, 2))
    with pytest.raises(KeyboardInterrupt):
        run(root, cfg_path)
    out = root / "results" / "tiny"
    assert (out / "cells/lift/EBC/si=0.02_sa=0_seed=0.json").exists()
    assert not (out / "cells/lift/EBC/si=0.02_sa=0_seed=1.json").exists()
    assert not list(out.rglob("*.tmp"))
    assert "| EBC | 0.00 [" in (out / "lift.md").read_text()  # the tables of the cells finished before the kill
    done = (out / "cells/lift/EBC/si=0.02_sa=0_seed=0.json").stat().st_mtime_ns

    monkeypatch.setattr(cells, "run_episodes", real)
    run(root, cfg_path)  # the same command again
    assert (out / "cells/lift/EBC/si=0.02_sa=0_seed=0.json").stat().st_mtime_ns == done  # not recomputed
    assert (out / "lift.csv").read_text() == (full / "lift.csv").read_text()
    assert (out / "lift.md").read_text() == (full / "lift.md").read_text()


@pytest.mark.slow
@pytest.mark.current_stack
def test_eval_cli_on_the_sweeps_checkpoint(dirs, capsys):
    root, _ = dirs
    ckpt = next((root / "ckpt" / "lift").glob("policy-seed0-*.ckpt"))
    rc = cli.main(["eval", "--ckpt", str(ckpt), "--sigma-init", "0.02", "0.3", "--episodes", "2", "--max-steps", "4"])
    out = capsys.readouterr().out
    assert rc == 0 and "| 0.3 | 0 |" in out and "EBC" in out and "scripted expert" in out and "simulator: MJX" in out


@pytest.mark.slow
@pytest.mark.needs_robosuite
def test_the_same_sweep_evaluated_in_robosuite(dirs, monkeypatch):
    """simulator: robosuite reuses the demos and checkpoints, writes each cell as it ends; cells and tables name the
    simulator."""
    root, _ = dirs
    cfg_path = root / "tiny-rs.json"
    cfg_path.write_text(json.dumps({**CFG, "name": "tiny-rs", "seeds": [0], "simulator": "robosuite"}))
    real = cells.run_episodes  # robosuite evaluates cell by cell: a run stopped in its second cell keeps the first
    monkeypatch.setattr(cells, "run_episodes", dies_on_call(real, 2))
    with pytest.raises(KeyboardInterrupt):
        run(root, cfg_path)
    first = root / "results/tiny-rs/cells/lift/EBC/si=0.02_sa=0_seed=0.json"
    assert first.exists() and not first.with_name("si=0.3_sa=0_seed=0.json").exists()
    assert "| EBC | 0.00 [0.00, 0.66] | - |" in (root / "results/tiny-rs/lift.md").read_text()  # its table too
    done = first.stat().st_mtime_ns
    monkeypatch.setattr(cells, "run_episodes", real)
    out = run(root, cfg_path)  # the same command again: only the missing cell runs
    assert first.stat().st_mtime_ns == done
    rec = json.loads((out / "cells/lift/EBC/si=0.3_sa=0_seed=0.json").read_text())
    assert rec["simulator"].startswith("robosuite 1.5") and rec["episodes"] == 2
    # how each episode ended (eval/outcomes.py): a label per episode, their counts adding up to the episodes
    assert len(rec["episode_outcomes"]) == 2 and rec["outcomes"]["success"] == rec["successes"]
    assert sum(v for k, v in rec["outcomes"].items() if k != "moved_object") == 2
    assert "Simulator: robosuite 1.5" in (out / "lift.md").read_text()
    assert len(list((root / "ckpt" / "lift").glob("policy-seed0-*.ckpt"))) == 1  # trained once, shared


def test_bad_input_exits_nonzero_and_touches_nothing(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**CFG, "methods": ["EBC", "GAIL"]}))
    rc = cli.main(["sweep", "--config", str(bad), "--results", str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert rc == 2 and "field 'methods': unknown method 'GAIL'" in err and err.count("\n") == 1
    assert not (tmp_path / "r").exists()
    rc = cli.main(["eval", "--ckpt", str(tmp_path / "none.ckpt")])
    assert rc == 2 and "no such checkpoint" in capsys.readouterr().err


ONLINE = {**CFG, "name": "tiny-online", "methods": ["POIR-DRIL online"], "sigma_init": [0.3], "seeds": [0],
          "overrides": {**CFG["overrides"], "online.total_env_steps": 16, "online.num_envs": 2, "online.eval_every": 8,
                        "online.buffer_capacity": 64}}  # fmt: skip


@pytest.mark.slow
def test_online_sweep_resumes_mid_run_and_plots_the_curve(tmp_path, monkeypatch):
    """Real Lift physics: 2 rounds of 2 episodes x 4 steps; killed in round 2, resumed, same tables."""
    from poir_mjx.online import loop

    cfg_path = tmp_path / "online.json"
    cfg_path.write_text(json.dumps(ONLINE))
    cfg = sw.load_sweep_config(cfg_path)
    full = sw.run_sweep(cfg, tmp_path / "a", tmp_path / "data", tmp_path / "ckpt-a", progress=False)
    rec = json.loads((full / "cells/lift/POIR-DRIL online/si=0.3_sa=0_seed=0.json").read_text())
    assert [c["env_steps"] for c in rec["curve"]] == [0, 8, 16] and len(rec["rounds"]) == 2
    assert rec["successes"] == rec["curve"][-1]["successes"] and rec["resumed_from_round"] == 0
    assert rec["rounds"][-1]["online_fraction"] == 0.0  # 16 gradient steps: still before the first increment
    assert rec["rounds"][0]["valid_transitions"] == 8 and rec["rounds"][0]["wm_error"] > 0
    md = (full / "lift.md").read_text()
    assert "### Online fine-tuning (lift)" in md and "| POIR-DRIL online, σ_init 0.3 | 0: " in md
    assert (full / "lift-online.png").stat().st_size > 0

    real = loop.finetune
    monkeypatch.setattr(loop, "finetune", dies_on_call(real, 2))
    with pytest.raises(KeyboardInterrupt):
        sw.run_sweep(cfg, tmp_path / "b", tmp_path / "data", tmp_path / "ckpt-b", progress=False)
    assert not (tmp_path / "b/tiny-online/cells/lift/POIR-DRIL online/si=0.3_sa=0_seed=0.json").exists()
    monkeypatch.setattr(loop, "finetune", real)
    out = sw.run_sweep(cfg, tmp_path / "b", tmp_path / "data", tmp_path / "ckpt-b", progress=False)
    again = json.loads((out / "cells/lift/POIR-DRIL online/si=0.3_sa=0_seed=0.json").read_text())
    assert again["resumed_from_round"] == 1
    assert [c["successes"] for c in again["curve"]] == [c["successes"] for c in rec["curve"]]
    assert [r["wm_error"] for r in again["rounds"]] == pytest.approx([r["wm_error"] for r in rec["rounds"]], rel=1e-6)


@pytest.mark.slow
@pytest.mark.needs_robosuite
def test_online_sweep_in_robosuite_collects_there_and_resumes(tmp_path, monkeypatch):
    """simulator robosuite: each round's deployments run in robosuite's workers (8 valid transitions of
    2 episodes x 4 steps), evaluations too; killed in round 2 and resumed, the same curve and errors."""
    from poir_mjx.online import loop

    cfg_path = tmp_path / "online-rs.json"
    cfg_path.write_text(json.dumps({**ONLINE, "name": "tiny-online-rs", "simulator": "robosuite"}))
    cfg = sw.load_sweep_config(cfg_path)
    monkeypatch.setattr(loop.OnlineTrainer, "collector", property(lambda self: pytest.fail("MJX was used")))
    full = sw.run_sweep(cfg, tmp_path / "a", tmp_path / "data", tmp_path / "ckpt-a", progress=False)
    rec = json.loads((full / "cells/lift/POIR-DRIL online/si=0.3_sa=0_seed=0.json").read_text())
    assert rec["simulator"].startswith("robosuite 1.5") and [c["env_steps"] for c in rec["curve"]] == [0, 8, 16]
    assert [r["valid_transitions"] for r in rec["rounds"]] == [8, 8] and rec["rounds"][0]["wm_error"] > 0
    real = loop.finetune
    monkeypatch.setattr(loop, "finetune", dies_on_call(real, 2))
    with pytest.raises(KeyboardInterrupt):
        sw.run_sweep(cfg, tmp_path / "b", tmp_path / "data", tmp_path / "ckpt-b", progress=False)
    monkeypatch.setattr(loop, "finetune", real)
    again = json.loads((sw.run_sweep(cfg, tmp_path / "b", tmp_path / "data", tmp_path / "ckpt-b", progress=False)
                        / "cells/lift/POIR-DRIL online/si=0.3_sa=0_seed=0.json").read_text())  # fmt: skip
    assert again["resumed_from_round"] == 1
    assert [c["successes"] for c in again["curve"]] == [c["successes"] for c in rec["curve"]]
    assert [r["wm_error"] for r in again["rounds"]] == pytest.approx([r["wm_error"] for r in rec["rounds"]], rel=1e-6)
