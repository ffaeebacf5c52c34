"""A sweep ranks with "balanced" unless it says "paper"; every published run, recorded before the field, reads as
"paper", and its experiments file still reproduces its recorded config."""

import dataclasses
import json
from pathlib import Path

import pytest

from poir_mjx.core.config import ConfigError
from poir_mjx.eval.methods import get_method
from poir_mjx.sweep import config as sweep_config
from poir_mjx.sweep.config import SweepConfig, base_config, load_sweep_config
from poir_mjx.sweep.run_folder import check_config, upgrade_recorded

from tests.core.test_ranking import LOW_DIM_NO_QUATERNIONS

ROOT = Path(__file__).resolve().parents[2]
# `make sweep` / `make sweep-online` and the GPU configs: the main jobs run today's default.
MAIN_JOBS = ("cpu-small.json", "cpu-small-online.json", "paper.json", "paper-online.json")


def test_a_sweep_plans_with_the_balanced_ranking_and_its_overrides_win():
    cfg = SweepConfig(name="t", tasks=("pick_place_can",), methods=("POIR-L2", "POIR-random"))
    assert cfg.ranking == "balanced"
    planner = base_config(cfg).planner
    assert (planner.selection, planner.l2_dims) == ("head_balanced", LOW_DIM_NO_QUATERNIONS)
    assert get_method("POIR-L2").agent_config(base_config(cfg)).planner.selection == "head_balanced"
    assert get_method("POIR-random").agent_config(base_config(cfg)).planner.selection == "random"  # the control
    paper = base_config(dataclasses.replace(cfg, ranking="paper")).planner
    assert (paper.selection, paper.l2_dims) == ("top_k", ())
    chosen = base_config(dataclasses.replace(cfg, overrides={"planner.selection": "top_k", "planner.l2_dims": [0]}))
    assert (chosen.planner.selection, chosen.planner.l2_dims) == ("top_k", (0,))
    # the agents do not depend on the ranking: one checkpoint serves both
    m = get_method("POIR-L2")
    assert m.training_config(base_config(cfg)) == m.training_config(base_config(dataclasses.replace(cfg, ranking="paper")))


def test_tasks_whose_quaternions_sit_apart_are_refused_in_one_base_config(monkeypatch):
    monkeypatch.setattr(sweep_config, "obs_groups", lambda task, observation: (
        ("position", "quaternion") if task == "lift" else ("quaternion", "position")))  # fmt: skip
    with pytest.raises(ConfigError, match="ranking: 'balanced' leaves the quaternions out of L2"):
        base_config(SweepConfig(name="t", tasks=("lift", "pick_place_can")))


def test_a_run_recorded_before_the_field_reads_as_paper_and_refuses_the_new_default(tmp_path):
    out = tmp_path / "run"
    (out / "cells" / "lift" / "EBC").mkdir(parents=True)
    (out / "cells" / "lift" / "EBC" / "c.json").write_text("{}")
    old = dataclasses.asdict(SweepConfig(name="run"))
    old.pop("ranking")
    (out / "config.json").write_text(json.dumps(old))
    assert load_sweep_config(out / "config.json", recorded=True).ranking == "paper"
    defaults = dataclasses.asdict(SweepConfig(name="run"))
    check_config(out, {**defaults, "ranking": "paper"}, defaults=defaults)  # the same run: accepted
    with pytest.raises(ConfigError, match=r"different config \(fields \['ranking'\]\)"):
        check_config(out, defaults, defaults=defaults)


def test_every_published_runs_experiments_file_reproduces_its_recorded_config():
    """As the sweep compares them (run_folder.check_config), without reading demo files this clone may lack."""
    checked = 0
    for path in sorted((ROOT / "experiments").rglob("*.json")):
        raw = json.loads(path.read_text())
        recorded_path = ROOT / "results" / raw["name"] / "config.json"
        if not recorded_path.is_file():
            continue
        defaults = json.loads(json.dumps(dataclasses.asdict(SweepConfig(name=raw["name"]))))
        recorded = {**defaults, **upgrade_recorded(json.loads(recorded_path.read_text()))}
        now = {**defaults, **json.loads(json.dumps(raw))}
        assert recorded["ranking"] == "paper"
        if path.name in MAIN_JOBS:
            assert now["ranking"] == "balanced" and {**now, "ranking": "paper"} == recorded, path
        else:
            assert now == recorded, path
        checked += 1
    assert checked > 50
