"""`report`: results/README.md generated from each published run's own files, and the committed one is current."""

import json
from pathlib import Path

from poir_mjx import cli
from poir_mjx.sweep.index import generate

ROOT = Path(__file__).resolve().parents[2]
TABLE = """## lift

Success rate (Wilson 95% interval), 2 episodes x 1 seed(s) per cell. Expert data: scripted expert. Simulator: MJX.

| method | σ_init 0.02 |
|---|---|
| EBC | 0.50 [0.09, 0.91] |
"""


def _results(tmp_path: Path) -> Path:
    results = tmp_path / "results"
    run = results / "tiny"
    run.mkdir(parents=True)
    cfg = {"name": "tiny", "tasks": ["lift"], "methods": ["EBC"], "episodes": 2, "max_steps": 4, "sigma_init": [0.02],
           "overrides": {"train.epochs": 1}}  # fmt: skip
    (run / "config.json").write_text(json.dumps(cfg))
    (run / "summary.md").write_text("# Sweep tiny\n")
    (run / "lift.md").write_text(TABLE)
    (run / "lift.png").write_bytes(b"png")
    (run / "notes.md").write_text("Made by a test on no machine at all.\n")
    unfinished = results / "unfinished"  # a run still going: no summary.md yet
    unfinished.mkdir()
    (unfinished / "config.json").write_text(json.dumps({**cfg, "name": "unfinished"}))
    (results / "bench").mkdir()
    (results / "bench" / "e2e.md").write_text("# End-to-end throughput\n")
    (results / "gpu").mkdir()
    (results / "gpu" / "notes.md").write_text("# The first GPU run\n")
    return results


def test_the_page_holds_each_runs_setup_notes_tables_and_plots(tmp_path, capsys):
    results = _results(tmp_path)
    assert cli.main(["report", "--results", str(results)]) == 0
    page = (results / "README.md").read_text()
    assert "python -m poir_mjx.cli report" in page.splitlines()[2] and "do not edit by hand" in page
    assert "## [tiny](tiny/)" in page and "unfinished" not in page
    assert "Tasks: lift. Methods: EBC. 2 episodes x 1 seed(s) per cell, max_steps 4" in page
    assert "overrides: train.epochs=1" in page and "Made by a test on no machine at all." in page
    assert "### lift" in page and "| EBC | 0.50 [0.09, 0.91] |" in page and "[lift.png](tiny/lift.png)" in page
    assert "- [bench/e2e.md](bench/e2e.md): End-to-end throughput" in page
    assert "- [gpu/notes.md](gpu/notes.md): The first GPU run" in page
    assert page == generate(results)


def test_check_fails_once_a_runs_table_changes(tmp_path, capsys):
    results = _results(tmp_path)
    assert cli.main(["report", "--results", str(results), "--check"]) == 1  # no page yet
    assert cli.main(["report", "--results", str(results)]) == 0
    assert cli.main(["report", "--results", str(results), "--check"]) == 0
    capsys.readouterr()
    (results / "tiny" / "lift.md").write_text(TABLE.replace("0.50", "1.00"))
    before = (results / "README.md").read_text()
    assert cli.main(["report", "--results", str(results), "--check"]) == 1
    out = capsys.readouterr().out
    assert out.count("\n") == 1 and "README.md: differs" in out
    assert (results / "README.md").read_text() == before  # --check writes nothing
    other = tmp_path / "index.md"
    assert cli.main(["report", "--results", str(results), "--out", str(other)]) == 0 and "1.00" in other.read_text()


def test_a_bad_run_config_is_one_line_naming_the_file_and_field(tmp_path, capsys):
    results = _results(tmp_path)
    (results / "tiny" / "config.json").write_text(json.dumps({"name": "tiny", "tasks": ["lift"]}))
    assert cli.main(["report", "--results", str(results)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "tiny/config.json: field 'methods' is missing" in err
    assert cli.main(["report", "--results", str(tmp_path / "none")]) == 2


def test_the_committed_results_readme_is_current():
    """Fails when a published run's files changed and `make report` was not run (or the page was edited)."""
    assert (ROOT / "results" / "README.md").read_text() == generate(ROOT / "results"), (
        "results/README.md is stale: run `python -m poir_mjx.cli report` (make report) and commit it")


def test_tables_are_rewritten_from_the_cell_records(tmp_path, capsys):
    """`report --tables`: a run's tables come back from its cell records in today's format; a run published
    without its cells keeps its tables."""
    from poir_mjx.sweep.artifacts import cell_hash, cell_path
    from poir_mjx.sweep.config import load_sweep_config

    results = _results(tmp_path)
    run = results / "grid"
    run.mkdir()
    raw = {"name": "grid", "tasks": ["lift"], "methods": ["EBC", "POIR-DRIL"], "episodes": 30, "max_steps": 4,
           "sigma_init": [0.02, 0.3]}  # fmt: skip
    (run / "config.json").write_text(json.dumps(raw))
    (run / "summary.md").write_text("# Sweep grid (an older version's tables)\n")
    cfg = load_sweep_config(run / "config.json", recorded=True)
    data = {"source": "scripted expert", "expert": "e", "simulator": "s", "num_demos": 1, "sha256": "d1g3st"}
    for method, counts in (("EBC", (20, 5)), ("POIR-DRIL", (24, 9))):
        for si, k in zip(cfg.sigma_init, counts):
            path = cell_path(run, "lift", method, si, 0.0, 0)
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps({"task": "lift", "method": method, "seed": 0, "episodes": 30, "successes": k,
                                        "diverged": 0, "config_hash": cell_hash(cfg, "lift", method, "d1g3st"),
                                        "data": data, "simulator": "robosuite"}))  # fmt: skip
    assert cli.main(["report", "--results", str(results), "--tables"]) == 0
    out = capsys.readouterr().out
    assert f"{run}: tables rewritten" in out and f"{results / 'tiny'}: no cell records" in out
    table = (run / "lift.md").read_text()
    assert "| POIR-DRIL | 0.80 [0.63, 0.90] | 0.30 [0.17, 0.48] |" in table and "| all cells |" in table
    assert "| POIR-DRIL | +4 (p " in table and "| +8 (p 0.14) |" in table  # 33 against 25 of 60, pooled
    assert (run / "lift.png").is_file() and "Sweep grid" in (run / "summary.md").read_text()
    assert (results / "tiny" / "lift.md").read_text() == TABLE
    assert "| POIR-DRIL | +4 (p " in (results / "README.md").read_text()


def test_in_a_git_work_tree_only_runs_whose_config_git_tracks_are_published(tmp_path):
    """A sweep still running beside committed ones (its folder untracked) stays off the page until it is added,
    so `make report` during a run writes the page a clean clone generates."""
    import shutil
    import subprocess

    import pytest

    if shutil.which("git") is None:
        pytest.skip("no git on this machine")
    results = _results(tmp_path)
    running = results / "running"
    running.mkdir()
    (running / "config.json").write_text((results / "tiny" / "config.json").read_text())
    (running / "summary.md").write_text("# Sweep running\n")
    assert "running" in generate(results)  # outside a git work tree: every finished-looking run
    subprocess.run(["git", "init", "-q", str(tmp_path)], check=True)
    subprocess.run(["git", "add", "results/tiny"], cwd=tmp_path, check=True)
    page = generate(results)
    assert "## [tiny](tiny/)" in page and "running" not in page
    subprocess.run(["git", "add", "results/running"], cwd=tmp_path, check=True)
    assert "## [running](running/)" in generate(results)


def test_a_runs_setup_names_human_like_demos():
    from poir_mjx.sweep.index import _setup

    cfg = {"tasks": ["lift"], "methods": ["EBC"], "episodes": 5, "max_steps": 400, "sigma_init": [0.1]}
    assert "Expert data: 200 scripted-expert demos recorded in robosuite." in _setup({**cfg, "num_demos": 200})
    human = _setup({**cfg, "num_demos": 200, "demo_style": "human_like"})
    assert "Expert data: 200 scripted-expert (human_like) demos recorded in robosuite." in human
