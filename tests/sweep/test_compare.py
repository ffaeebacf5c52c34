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
    cfg = {"name": name, "ranking": "balanced", "overrides": overrides, "demo_files": demo_files or {}}
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


def _seeded(root, name, cells, sigma_init=(0.02, 0.3), sigma_action=(0.0,), episodes=10, labels=None):
    """A run folder with per-seed cells (method, si, sa, seed, k) of `episodes` episodes each (labels: each cell's
    episode_outcomes, in order)."""
    run = root / name
    (run / "cells").mkdir(parents=True)
    cfg = {"name": name, "ranking": "balanced", "sigma_init": list(sigma_init), "sigma_action": list(sigma_action), "seeds": [0, 1],
           "episodes": episodes}  # fmt: skip
    (run / "config.json").write_text(json.dumps(cfg))
    sweep = SweepConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in cfg.items()})
    for j, (method, si, sa, seed, k) in enumerate(cells):
        rec = {"task": "lift", "method": method, "sigma_init": si, "sigma_action": sa, "seed": seed, "successes": k,
               "episodes": episodes, "config_hash": cell_hash(sweep, "lift", method, "abc"), "data": {"sha256": "abc"}}
        if labels is not None:
            rec["episode_outcomes"] = labels[j]
        (run / "cells" / f"{j}.json").write_text(json.dumps(rec))
    return run


def test_versus_pairs_cells_by_seed_and_pools_the_seeds(tmp_path):
    from poir_mjx.eval.episodes import agreement_p_value
    from poir_mjx.eval.stats import pooled_p_value

    ref = _seeded(tmp_path, "noise", [("EBC", 0.02, 0.05, 0, 5), ("EBC", 0.02, 0.05, 1, 6), ("EBC", 0.3, 0.05, 0, 1)],
                  sigma_action=(0.05,))  # fmt: skip
    base = _seeded(tmp_path, "base", [("POIR-DRIL", 0.02, 0.0, 0, 9), ("POIR-DRIL", 0.02, 0.0, 1, 8),
                                      ("POIR-DRIL", 0.3, 0.0, 0, 4), ("POIR-DRIL", 0.3, 0.0, 1, 3)])  # fmt: skip
    text = compare([base, ref], versus=((ref, "EBC"),))
    row = next(line for line in text.split("Versus noise:EBC")[1].splitlines() if line.startswith("| base | POIR-DRIL"))
    cells = [c.strip() for c in row.strip("|").split("|")][2:]
    # sigma_init 0.02: both seeds matched (other sigma_action, the reference's only one), pooled over the seeds
    assert cells[0] == f"+6 (p {pooled_p_value([(9, 10, 5, 10), (8, 10, 6, 10)]):.2g})"
    # sigma_init 0.3: the reference has seed 0 only; one pair is a Fisher test
    assert cells[1] == f"+3 (p {agreement_p_value(4, 10, 1, 10):.2g})"
    assert cells[2] == f"+9 (p {pooled_p_value([(9, 10, 5, 10), (8, 10, 6, 10), (4, 10, 1, 10)]):.2g})"
    assert "‡" not in text  # same seeds, grid positions and episode counts: the same starting states


def test_versus_marks_other_starting_states_and_names_a_missing_row(tmp_path):
    ref = _seeded(tmp_path, "ref", [("EBC", 0.3, 0.0, 0, 2)])
    moved = _seeded(tmp_path, "moved", [("EBC", 0.3, 0.0, 0, 7)], sigma_init=(0.1, 0.2, 0.3))  # another grid position
    text = compare([moved, ref], versus=((ref, "EBC"),))
    assert "+5 (p " in text and "‡" in text and "not a paired comparison" in text
    with pytest.raises(Exception, match=r"--versus: no row ref:POIR-DRIL .*rows: moved:EBC, ref:EBC"):
        compare([moved, ref], versus=((ref, "POIR-DRIL"),))
    rc = cli.main(["compare", str(moved), "--versus", "no-colon"])
    assert rc == 2


def test_methods_keeps_those_rows_and_the_reference(tmp_path):
    ref = _seeded(tmp_path, "ref", [("EBC", 0.3, 0.0, 0, 2), ("POIR-DRIL", 0.3, 0.0, 0, 4)])
    other = _seeded(tmp_path, "other", [("EBC", 0.3, 0.0, 0, 3), ("POIR-DRIL", 0.3, 0.0, 0, 5)])
    text = compare([other, ref], versus=((ref, "EBC"),), methods=("POIR-DRIL",))
    assert "| ref | - | EBC |" in text and "| other | - | EBC |" not in text and "| ref | - | POIR-DRIL |" in text
    assert "| other | POIR-DRIL | +3 (p " in text


def test_a_method_in_several_runs_is_also_pooled_over_them(tmp_path):
    from poir_mjx.eval.stats import pooled_p_value

    ref = _seeded(tmp_path, "ref", [("EBC", 0.3, 0.0, 0, 2), ("EBC", 0.3, 0.0, 1, 3)])
    a = _seeded(tmp_path, "a", [("POIR-DRIL", 0.3, 0.0, 0, 6)])
    b = _seeded(tmp_path, "b", [("POIR-DRIL", 0.3, 0.0, 1, 8)])
    text = compare([a, b, ref], versus=((ref, "EBC"),))
    both = pooled_p_value([(6, 10, 2, 10), (8, 10, 3, 10)])
    assert f"| all 2 runs | POIR-DRIL | +9 (p {both:.2g}) | +9 (p {both:.2g}) |" in text


def test_episode_by_episode_where_both_cells_record_how_each_episode_ended(tmp_path):
    stall, away, ok = "stalled_at_object", "ran_away", "success"
    ref = _seeded(tmp_path, "ref", [("EBC", 0.3, 0.0, 0, 1)], episodes=4, labels=[[ok, stall, stall, away]])
    row = _seeded(tmp_path, "row", [("EBC", 0.3, 0.05, 0, 3)], sigma_action=(0.05,), episodes=4,
                  labels=[[ok, ok, ok, away]])  # fmt: skip
    text = compare([row, ref], versus=((ref, "EBC"),))
    assert "Episode by episode on the same starts" in text
    assert "| row | EBC | stalled_at_object | 2 | 2 | 0 | 0 | 0 | 0 | 0 |" in text  # both stalls now succeed
    assert "| row | EBC | ran_away | 1 | 0 | 0 | 1 | 0 | 0 | 0 |" in text
    moved = _seeded(tmp_path, "moved", [("EBC", 0.3, 0.0, 0, 3)], sigma_init=(0.1, 0.2, 0.3), episodes=4,
                    labels=[[ok, ok, ok, away]])  # fmt: skip
    assert "Episode by episode" not in compare([moved, ref], versus=((ref, "EBC"),))  # other starts: not paired


def test_runs_of_other_noise_cells_are_not_pooled(tmp_path):
    ref = _seeded(tmp_path, "ref", [("EBC", 0.3, 0.1, 0, 2), ("EBC", 0.3, 0.1, 1, 3)], sigma_action=(0.1,))
    a = _seeded(tmp_path, "a", [("EBC", 0.3, 0.0, 0, 6)])
    b = _seeded(tmp_path, "b", [("EBC", 0.3, 0.0, 1, 8)])
    c = _seeded(tmp_path, "c", [("EBC", 0.3, 0.03, 1, 7)], sigma_action=(0.03,))  # another action noise
    text = compare([a, b, c, ref], versus=((ref, "EBC"),))
    assert "| all 2 runs | EBC |" in text and "all 3 runs" not in text


def test_runs_of_other_sigma_init_grids_are_pooled_but_never_one_seed_twice(tmp_path):
    from poir_mjx.eval.stats import pooled_p_value

    ref = _seeded(tmp_path, "ref", [("EBC", 0.02, 0.0, 0, 2), ("EBC", 0.02, 0.0, 1, 3), ("EBC", 0.3, 0.0, 1, 1)])
    a = _seeded(tmp_path, "a", [("POIR-DRIL", 0.02, 0.0, 0, 6)])  # seed 0: one cell
    b = _seeded(tmp_path, "b", [("POIR-DRIL", 0.02, 0.0, 1, 8), ("POIR-DRIL", 0.3, 0.0, 1, 4)])  # seed 1: two
    text = compare([a, b, ref], versus=((ref, "EBC"),))
    every = pooled_p_value([(6, 10, 2, 10), (8, 10, 3, 10), (4, 10, 1, 10)])
    assert f"| all 2 runs | POIR-DRIL | +9 (p " in text and f"| +12 (p {every:.2g}) |" in text
    again = _seeded(tmp_path, "again", [("POIR-DRIL", 0.02, 0.0, 1, 7)])  # seed 1 again: not pooled with b
    assert "all 2 runs" not in compare([b, again, ref], versus=((ref, "EBC"),))


def test_several_references_act_as_one_row_of_all_their_cells(tmp_path):
    from poir_mjx.eval.stats import pooled_p_value

    ref0 = _seeded(tmp_path, "ref0", [("EBC", 0.3, 0.0, 0, 2)])
    ref1 = _seeded(tmp_path, "ref1", [("EBC", 0.3, 0.0, 1, 3)])
    a = _seeded(tmp_path, "a", [("POIR-DRIL", 0.3, 0.0, 0, 6)])
    b = _seeded(tmp_path, "b", [("POIR-DRIL", 0.3, 0.0, 1, 8)])
    text = compare([a, b, ref0, ref1], versus=((ref0, "EBC"), (ref1, "EBC")))
    both = pooled_p_value([(6, 10, 2, 10), (8, 10, 3, 10)])
    assert "Versus ref0:EBC + ref1:EBC" in text
    assert f"| all 2 runs | POIR-DRIL | +9 (p {both:.2g}) | +9 (p {both:.2g}) |" in text
    versus = text.split("Versus")[1]
    assert "| a | POIR-DRIL | +4 (p " in versus and "| ref0 | EBC |" not in versus and "| ref1 | EBC |" not in versus
    with pytest.raises(Exception, match=r"--versus: ref0:EBC and a:POIR-DRIL both have lift sigma_init 0.3 .*seed 0"):
        compare([a, ref0], versus=((ref0, "EBC"), (a, "POIR-DRIL")))
    out = tmp_path / "t.md"
    assert cli.main(["compare", str(a), str(b), "--versus", f"{ref0}:EBC", f"{ref1}:EBC", "--out", str(out)]) == 0
    assert f"| all 2 runs | POIR-DRIL | +9 (p {both:.2g})" in out.read_text()


def _ran(run, ckpt, digest=None):
    """Marks every cell of `run` as having run checkpoint `ckpt` (with the file digest, where given)."""
    for f in (run / "cells").glob("*.json"):
        rec = json.loads(f.read_text())
        rec.update({"checkpoint": f"checkpoints/lift/{ckpt}", **({"checkpoint_sha256": digest} if digest else {})})
        f.write_text(json.dumps(rec))
    return run


def test_each_runs_agents_and_one_checkpoint_name_with_two_digests(tmp_path):
    """Cells paired across runs (e.g. with an agent retrained from the same key on another day) say which file ran
    them; two digests under one checkpoint name are a warning line, one digest (or none recorded) is not."""
    def page(*runs):
        out = tmp_path / "page.md"
        assert cli.main(["compare", *map(str, runs), "--versus", f"{ref}:EBC", "--out", str(out)]) == 0
        return out.read_text()

    ref = _ran(_seeded(tmp_path, "ref", [("EBC", 0.3, 0.0, 0, 2)]), "policy-seed0-k.ckpt", "aaaa")
    same = _ran(_seeded(tmp_path, "same", [("EBC", 0.3, 0.0, 0, 5)]), "policy-seed0-k.ckpt", "aaaa")
    old = _ran(_seeded(tmp_path, "old", [("EBC", 0.3, 0.0, 0, 5)]), "policy-seed0-k.ckpt")
    text = page(same, old, ref)
    assert "- ref: " in text and "; agents policy-seed0-k.ckpt (sha256 aaaa)" in text
    assert "; agents policy-seed0-k.ckpt (sha256 not recorded)" in text and "different agents" not in text
    other = _ran(_seeded(tmp_path, "other", [("EBC", 0.3, 0.0, 0, 5)]), "policy-seed0-k.ckpt", "bbbb")
    assert ("- **policy-seed0-k.ckpt: different agents under one name**, sha256 aaaa in same, ref; sha256 bbbb in other"
            in page(same, other, ref))
