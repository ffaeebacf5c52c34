import dataclasses
import json

import pytest

from poir_mjx.core.config import ConfigError
from poir_mjx.eval.methods import get_method
from poir_mjx.eval.stats import pooled_p_value, wilson_interval
from poir_mjx.sweep.artifacts import cell_hash
from poir_mjx.sweep.config import base_config, load_sweep_config


def test_wilson_interval_known_values():
    # Reference values (Wilson 1927; e.g. statsmodels proportion_confint(method="wilson")).
    lo, hi = wilson_interval(8, 10)
    assert lo == pytest.approx(0.4902, abs=1e-4) and hi == pytest.approx(0.9433, abs=1e-4)
    lo, hi = wilson_interval(0, 20)
    assert lo == 0.0 and hi == pytest.approx(0.1611, abs=1e-4)
    lo, hi = wilson_interval(20, 20)
    assert lo == pytest.approx(0.8389, abs=1e-4) and hi == 1.0
    for n in range(1, 60):  # the interval contains the observed rate, also at 0 and n
        for k in (0, n):
            lo, hi = wilson_interval(k, n)
            assert lo <= k / n <= hi
    with pytest.raises(ValueError, match="successes"):
        wilson_interval(11, 10)
    with pytest.raises(ValueError, match="n:"):
        wilson_interval(0, 0)


def test_pooled_p_value_known_values():
    # R's mantelhaen.test example (penicillin and rabbits, 5 strata): Mantel-Haenszel X-squared 3.9286, p 0.04747.
    rabbits = [(0, 6, 0, 5), (3, 6, 0, 6), (6, 6, 2, 6), (5, 6, 6, 6), (2, 2, 5, 5)]
    assert pooled_p_value(rabbits) == pytest.approx(0.04747, abs=1e-5)
    # One stratum: the continuity-corrected statistic is Yates' chi-square times (N - 1) / N.
    from scipy.stats import chi2, chi2_contingency

    yates = chi2_contingency([[20, 10], [12, 18]], correction=True).statistic
    assert pooled_p_value([(20, 30, 12, 30)]) == pytest.approx(chi2.sf(yates * 59 / 60, 1))
    assert pooled_p_value([(5, 30, 5, 30), (9, 30, 9, 30)]) == 1.0  # the same counts: no difference
    assert pooled_p_value([(30, 30, 30, 30), (0, 30, 0, 30)]) == 1.0  # no variance in any stratum
    # Consistent small leads add up: each cell alone is far from significant, together they are.
    lead = [(18, 30, 12, 30)] * 6
    assert pooled_p_value(lead) < 0.01 < pooled_p_value(lead[:1])


def test_shipped_sweep_configs():
    cfg = load_sweep_config("experiments/cpu-small.json")
    assert cfg.tasks == ("lift",) and cfg.methods == ("EBC", "POIR-DRIL") and cfg.sigma_init == (0.02, 0.2, 0.4)
    assert load_sweep_config("experiments/paper.json").seeds == (0, 1, 2, 3, 4)
    online = load_sweep_config("experiments/cpu-small-online.json")
    assert "POIR-DRIL online" in online.methods and online.tasks == ("lift",)
    paper_online = load_sweep_config("experiments/paper-online.json")
    assert base_config(paper_online).online.total_env_steps == 500_000


def test_offline_cells_and_checkpoints_ignore_online_settings():
    a = load_sweep_config("experiments/cpu-small.json")
    b = dataclasses.replace(a, overrides={"online.total_env_steps": 123})
    assert cell_hash(a, "lift", "POIR-DRIL", "d") == cell_hash(b, "lift", "POIR-DRIL", "d")
    assert cell_hash(a, "lift", "POIR-DRIL online", "d") != cell_hash(b, "lift", "POIR-DRIL online", "d")
    assert cell_hash(a, "lift", "POIR-DRIL", "d") != cell_hash(a, "lift", "POIR-DRIL", "e")  # other demo content


@pytest.mark.parametrize(
    "patch, match",
    [
        ({"methods": ["EBC", "GAIL"]}, "field 'methods': unknown method 'GAIL'"),
        ({"tasks": ["door"]}, "field 'tasks': 'door' is not one of"),
        ({"sigma_init": [0.1, -0.2]}, "field 'sigma_init': must be >= 0, got -0.2"),
        ({"sigma_init": [0.1, float("nan")]}, "field 'sigma_init': must be finite, got nan"),
        ({"simulator": "gazebo"}, "field 'simulator': 'gazebo' is not one of"),
        ({"overrides": {"online.simulator": "gazebo"}}, "field 'overrides': online.simulator: 'gazebo' is not one of"),
        ({"workers": -1}, "field 'workers': must be >= 0, got -1"),
        ({"overrides": {"normalizer.quaternion_std_floor": float("nan")}}, "field 'overrides': normalizer.quaternion_std_floor: must be finite"),
        ({"overrides": {"planner.reward_timing": "later"}}, "field 'overrides': planner.reward_timing: 'later' is not one of"),
        ({"sigma_init": []}, "field 'sigma_init': must be a non-empty list"),
        ({"episodes": "10"}, "field 'episodes': expected an integer, got '10'"),
        ({"sigma_action": ["0.1"]}, "field 'sigma_action': expected a number, got '0.1'"),
        ({"preset": "huge"}, "field 'preset'"),
        ({"episodez": 3}, r"unknown field\(s\) \['episodez'\]"),
        ({"demo_files": {"lift": "/nonexistent.hdf5"}}, "field 'demo_files.lift': no such file"),
        ({"overrides": {"online.num_envz": 3}}, "field 'overrides': 'online.num_envz' is not a config field"),
        ({"overrides": {"online.mix_max": 2.0}}, "field 'overrides': online.mix_max: a fraction must be in"),
        ({"overrides": {"online.total_env_steps": "1e4"}}, "field 'overrides': online.total_env_steps: expected an integer"),
    ],
)
def test_malformed_config_names_the_field(tmp_path, patch, match):
    raw = json.loads(open("experiments/cpu-small.json").read())
    raw.update(patch)
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(raw))
    with pytest.raises(ConfigError, match=r"bad\.json: " + match):
        load_sweep_config(f)


def test_new_sweep_fields_are_validated(tmp_path):
    base = {"name": "x", "tasks": ["lift"], "methods": ["EBC"]}
    for field, value, msg in (("demo_simulator", "gazebo", "field 'demo_simulator'"),
                              ("device", "tpu", "field 'device'"), ("demo_batch", 0, "field 'demo_batch'"),
                              ("demo_style", "humanlike", "field 'demo_style': .*human_like")):  # fmt: skip
        f = tmp_path / f"{field}.json"
        f.write_text(json.dumps({**base, field: value}))
        with pytest.raises(ConfigError, match=msg):
            load_sweep_config(f)
    f = tmp_path / "ok.json"
    f.write_text(json.dumps({**base, "demo_simulator": "mjx", "demo_batch": 4, "device": "cpu", "demo_style": "human_like"}))
    cfg = load_sweep_config(f)
    assert cfg.demo_simulator == "mjx" and cfg.device == "cpu" and cfg.demo_style == "human_like"
    assert load_sweep_config("experiments/cpu-prior-human-demos.json").demo_style == "human_like"
    assert load_sweep_config("experiments/cpu-small.json").demo_style == "scripted"  # the default


def test_gpu_requested_without_a_gpu_is_one_line_and_exit_2(tmp_path, capsys):
    import jax

    from poir_mjx import cli

    if jax.default_backend() == "gpu":
        pytest.skip("a GPU is visible here")
    f = tmp_path / "gpu.json"
    f.write_text(json.dumps({"name": "gpu-check", "tasks": ["lift"], "methods": ["EBC"], "device": "gpu"}))
    rc = cli.main(["sweep", "--config", str(f), "--results", str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "field 'device': a GPU was requested but jax" in err, err
    assert not (tmp_path / "r").exists()


class _Stop(Exception):
    pass


@pytest.mark.parametrize("tasks,simulator,demo_simulator,noted", [
    (("nut_assembly_square",), "robosuite", "mjx", True),
    (("nut_assembly_square",), "mjx", "robosuite", True),
    (("nut_assembly_square",), "robosuite", "robosuite", False),
    (("lift",), "mjx", "mjx", False),
])  # fmt: skip
def test_a_sweep_notes_square_in_float32_mjx(tasks, simulator, demo_simulator, noted, tmp_path, monkeypatch, capsys):
    """Square's scripted expert fails 12 of 32 episodes in float32 MJX: a sweep that steps it there says so once."""
    import poir_mjx.sweep.run as run
    from poir_mjx.sweep.config import SweepConfig

    def stop(*args, **kwargs):
        raise _Stop

    monkeypatch.setattr(run, "demos_for", stop)  # the note comes before any work
    cfg = SweepConfig(name="note", tasks=tasks, methods=("EBC",), simulator=simulator, demo_simulator=demo_simulator)
    with pytest.raises(_Stop):
        run.run_sweep(cfg, tmp_path / "results", tmp_path / "data", tmp_path / "ckpt")
    err = capsys.readouterr().err
    assert ("NutAssemblySquare in MJX runs in float32" in err) == noted
    assert ('"x64": true in the sweep config runs the physics in float64' in err) == noted
    with pytest.raises(_Stop):  # a float64 sweep gets no note
        run.run_sweep(dataclasses.replace(cfg, x64=True), tmp_path / "results", tmp_path / "data", tmp_path / "ckpt",
                      replace_config=True)  # fmt: skip
    assert "NutAssemblySquare in MJX runs in float32" not in capsys.readouterr().err


def test_physics_preset_keys_the_cells_and_reaches_every_mjx_episode(tmp_path, monkeypatch):
    """A run's `physics` names the MJX physics preset: absent from the cell hash at "reference" (published cells keep
    theirs), part of it otherwise; refused where nothing steps MJX; handed to the MJX evaluator's environment."""
    from poir_mjx.eval import episodes

    base = {"name": "x", "tasks": ["lift"], "methods": ["EBC"]}
    f = tmp_path / "c.json"
    cfgs = {}
    for physics in (None, "reference", "fast", "fast-capped"):
        f.write_text(json.dumps({**base, **({"physics": physics} if physics else {})}))
        cfgs[physics] = load_sweep_config(f)
    h = {p: cell_hash(c, "lift", "EBC", "d") for p, c in cfgs.items()}
    assert h[None] == h["reference"] != h["fast"] != h["fast-capped"] != h[None]
    f.write_text(json.dumps({**base, "physics": "fast", "simulator": "robosuite"}))
    with pytest.raises(ConfigError, match=r"c\.json: field 'physics': 'fast' sets MJX's physics, and nothing"):
        load_sweep_config(f)
    f.write_text(json.dumps({**base, "physics": "fastest"}))
    with pytest.raises(ConfigError, match=r"c\.json: field 'physics': 'fastest' is not one of"):
        load_sweep_config(f)

    seen = []
    monkeypatch.setattr(episodes, "make_env", lambda task, observation, physics: seen.append(physics) or 1 / 0)
    episodes.mjx_evaluator.cache_clear()
    with pytest.raises(ZeroDivisionError):
        episodes.run_episodes("mjx", "lift", get_method("EBC"), None, None, None, None, None, 1, physics="fast")
    assert seen == ["fast"]


def test_the_e2e_bench_and_a_sweep_cell_share_one_compiled_evaluator(monkeypatch):
    """bench e2e asks for the evaluator with the defaults left out, a sweep cell with them written: one build, so the
    GPU check's cell and sweep stages reuse the e2e stage's programs (they compiled them again, 3 minutes each)."""
    from poir_mjx.eval import episodes
    from poir_mjx.eval.methods import get_method

    built = []
    monkeypatch.setattr(episodes, "make_env", lambda task, observation, physics: built.append(physics))
    monkeypatch.setattr(episodes, "make_evaluator", lambda env, policy, steps: object())
    episodes.mjx_evaluator.cache_clear()
    method = get_method("EBC")
    e2e = episodes.mjx_evaluator("lift", method, None, 4)  # poir_mjx/bench/e2e.py
    assert episodes.mjx_evaluator("lift", method, None, 4, "low_dim", "reference") is e2e  # sweep/cells.py's call
    assert episodes.mjx_evaluator("lift", method, None, 4, physics="fast") is not e2e and built == ["reference", "fast"]
    episodes.mjx_evaluator.cache_clear()


def test_warp_physics_in_a_sweep_is_refused_where_it_cannot_run(tmp_path):
    """physics "warp": one line naming the field where MuJoCo Warp is missing; where it is installed, refused for the
    methods whose environments its batch-shared contact buffers do not fit (baselines, the oracle controls)."""
    from poir_mjx.optional import warp_installed

    f = tmp_path / "c.json"
    f.write_text(json.dumps({"name": "x", "tasks": ["lift"], "methods": ["EBC", "DAC", "POIR-L2 oracle"],
                             "simulator": "mjx", "physics": "warp"}))  # fmt: skip
    if not warp_installed():
        with pytest.raises(ConfigError, match=r"c\.json: field 'physics': 'warp' needs mujoco-mjx 3.17 or newer"):
            load_sweep_config(f)
        return
    with pytest.raises(ConfigError, match=r"c\.json: .*'warp' shares contact buffers .* DAC, POIR-L2 oracle"):
        load_sweep_config(f)
    f.write_text(json.dumps({"name": "x", "tasks": ["lift"], "methods": ["EBC"], "simulator": "mjx",
                             "physics": "warp"}))  # fmt: skip
    assert load_sweep_config(f).physics == "warp"
