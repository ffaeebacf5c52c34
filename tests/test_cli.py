"""The one command line (poir_mjx/cli): generated from the typed configs, one-line errors, exit status 2.
Nothing here compiles MJX: parsing, help and the sweep's config checks run before any physics."""

import dataclasses
import json

import pytest

from poir_mjx import cli
from poir_mjx.cli import run
from poir_mjx.flags import dotted
from poir_mjx.options import DemosGenerate, POIRFlags
from poir_mjx.cli.parser import Command, parse
from poir_mjx.core.config import POIRConfig, to_dict
from poir_mjx.sweep.config import base_config, load_sweep_config


def _parse(*argv):
    return parse(cli.COMMANDS, cli.GROUPS, list(argv), cli.PROG)


def _leaves(d: dict, prefix=""):
    for k, v in d.items():
        yield from _leaves(v, f"{prefix}{k}.") if isinstance(v, dict) else [prefix + k]


def _config(tmp_path, **fields):
    f = tmp_path / "c.json"
    f.write_text(json.dumps({"name": "x", "tasks": ["lift"], "methods": ["EBC"], **fields}))
    return f


def test_help_renders_for_every_subcommand(capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(["--help"])
    assert e.value.code == 0
    top = capsys.readouterr().out
    for c in cli.COMMANDS:
        assert c.name.split()[0] in top
        with pytest.raises(SystemExit) as e:
            cli.main([*c.name.split(), "--help"])
        assert e.value.code == 0, c.name
        assert c.options_type().__doc__.split()[0] in capsys.readouterr().out, c.name


def test_every_poir_field_is_a_sweep_flag_with_its_docstring(capsys):
    fields = list(_leaves(to_dict(POIRConfig())))
    assert len(fields) > 30 and "normalizer.clip" in fields
    flags = POIRFlags()
    for name in fields:  # every leaf of POIRConfig has an unset flag of the same dotted name
        node = flags
        for part in name.split("."):
            node = getattr(node, part)
        assert node is None, name
    with pytest.raises(SystemExit):
        cli.main(["sweep", "--help"])
    out = capsys.readouterr().out
    for flag in ("--ensemble-size", "--planner.top-k", "--normalizer.position-std-floor", "--online.num-envs"):
        assert flag in out, flag
    assert "Smallest std of a quaternion component" in out  # the field's docstring is its help


def test_poir_flags_reach_the_sweep_config_on_top_of_the_files_overrides(tmp_path):
    f = _config(tmp_path, overrides={"planner.sigma": 0.3, "planner.top_k": 2})
    command, opts = _parse("sweep", "--config", str(f), "--planner.sigma", "0.1", "--normalizer.clip", "5",
                           "--online.total_env_steps", "64", "--planner.use-prior", "False")  # fmt: skip
    assert command.name == "sweep"
    flags = dotted(opts.poir)
    assert flags == {"planner.sigma": 0.1, "planner.use_prior": False, "normalizer.clip": 5.0,
                     "online.total_env_steps": 64}  # fmt: skip
    cfg = run.with_flags(load_sweep_config(f), flags)
    assert cfg.overrides == {"planner.sigma": 0.1, "planner.top_k": 2, "planner.use_prior": False,
                             "normalizer.clip": 5.0, "online.total_env_steps": 64}  # fmt: skip
    poir = base_config(cfg)
    assert (poir.planner.sigma, poir.planner.top_k, poir.normalizer.clip) == (0.1, 2, 5.0)
    assert poir.ensemble_size == 5  # the file's preset (cpu-small) for every field no flag set


def test_eval_takes_the_planner_fields_but_not_the_ones_its_method_picks(capsys):
    _, opts = _parse("eval", "--ckpt", "x.ckpt", "--planner.top-k", "3", "--sigma-init", "0.02", "0.3")
    assert dotted(opts.planner, "planner.") == {"planner.top_k": 3} and opts.sigma_init == (0.02, 0.3)
    assert _parse("eval", "--ckpt", "x.ckpt", "--planner.reward", "l2").startswith("unrecognised arguments")


def test_eval_plans_with_the_balanced_ranking_unless_told_and_its_planner_flags_win():
    from poir_mjx.cli.evaluate import planner_config
    from poir_mjx.core.config import preset

    _, opts = _parse("eval", "--ckpt", "x.ckpt")
    assert opts.ranking == "balanced" and _parse("eval", "--ckpt", "x.ckpt", "--ranking", "paper")[1].ranking == "paper"
    base = preset("cpu-small")
    cfg = planner_config(base, "balanced", {}, "pick_place_can", "object")
    assert (cfg.planner.selection, cfg.planner.l2_dims) == ("head_balanced", (0, 1, 2, 7, 8, 9))
    assert planner_config(base, "paper", {}, "pick_place_can", "low_dim") == base
    flagged = planner_config(base, "balanced", {"planner.selection": "top_k"}, "lift", "low_dim")
    assert flagged.planner.selection == "top_k" and len(flagged.planner.l2_dims) == 11


@pytest.mark.parametrize(
    "argv, match",
    [
        (["sweep", "--config", "{f}", "--planner.sigma", "abc"], "--planner.sigma"),
        (["sweep", "--config", "{f}", "--planner.sigma", "-1"], "command line: planner.sigma: must be >= 0"),
        (["sweep", "--config", "{f}", "--planner.top-k", "1000"], "planner.top_k: 1000 exceeds num_trajectories"),
        (["sweep", "--config", "{f}", "--planner.reward", "gail"], "--planner.reward: 'gail' is not one of"),
        (["sweep"], "poir-mjx sweep: missing --config"),
        (["eval", "--ckpt", "x", "--episodes", "0"], "--episodes: must be positive"),
        (["eval", "--ckpt", "x", "--sigma-init"], "--sigma-init: give at least one value"),
        (["bench"], "expected a subcommand, one of env, physics, planner, e2e, robosuite"),
        (["demos", "generate", "--simulator", "gazebo"], "--simulator: 'gazebo' is not one of robosuite, mjx"),
        (["demos", "generate", "--demo-style", "human"], "--demo-style: 'human' is not one of scripted, human_like"),
        (["demos", "spread"], "missing --data"),
        (["demos", "spread", "--data", "/nonexistent.hdf5"], "/nonexistent.hdf5: no such file"),
        (["compare"], "RUNS: give at least one value"),
        (["sweep", "--config", "{f}", "--bogus"], "unrecognised arguments: --bogus"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, argv, match):
    f = _config(tmp_path)
    rc = cli.main([a.replace("{f}", str(f)) for a in argv])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and match in err, err
    assert not (tmp_path / "results").exists()


def test_demos_alone_is_demos_generate():
    command, opts = _parse("demos")
    assert command.name == "demos generate" and opts == DemosGenerate()


def test_a_subcommand_is_one_registration(capsys):
    @dataclasses.dataclass(frozen=True)
    class Toy:
        """A toy subcommand."""

        level: int = 1
        """How much."""

    commands = (*cli.COMMANDS, Command("toy", Toy, lambda o: o.level + 40))
    command, opts = parse(commands, cli.GROUPS, ["toy", "--level", "2"], cli.PROG)
    assert command.function()(opts) == 42
    lazy = Command("sweep", "poir_mjx.options:Sweep", "poir_mjx.cli.run:sweep")
    assert lazy.options_type() is cli.COMMANDS[0].options_type() and lazy.function() is run.sweep
