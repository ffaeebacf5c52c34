"""The expert's MJX success measurement (poir_mjx/eval/expert_success.py): batching does not change the episodes,
finished batches are kept, an interrupted run resumes after them, a foreign record is refused by field.

The MJX rollout is replaced by a stand-in whose outcomes are a function of each episode's key, so these tests check
the bookkeeping (key order, padding, resume) without compiling the physics; the gpucheck dry run runs the real one."""

import json

import numpy as np
import pytest

from poir_mjx.cli.demos import run_success
from poir_mjx.core.config import ConfigError
from poir_mjx.data import mjx_demos
from poir_mjx.eval import expert_success as es
from poir_mjx.options import DemosSuccess
from tests.helpers import x64

SIGMA = 0.02


def outcome(keys):
    """The stand-in's per-episode outcome: (first success step or -1, diverged), a function of the key alone."""
    k = np.asarray(keys, np.int64)
    return np.where(k[:, 1] % 3 == 0, -1, 10 + k[:, 1] % 40), k[:, 0] % 4 == 0


class StandIn:
    def __init__(self, fail_after: int | None = None):
        self.calls, self.batches, self.fail_after, self.physics = 0, [], fail_after, []

    def __call__(self, task, steps, style="scripted", physics="reference"):
        self.physics.append(physics)
        def rollout(_, keys, env_params):
            if self.fail_after is not None and self.calls >= self.fail_after:
                raise KeyboardInterrupt
            self.calls += 1
            self.batches.append(len(keys))
            assert len(env_params.sigma_init) == len(keys)
            first, div = outcome(keys)
            return {"first_success": first, "diverged": div}, None

        return rollout


def expected(episodes, seed=1):
    import jax

    first, div = outcome(jax.random.split(jax.random.PRNGKey(seed), episodes))
    ok = first >= 0
    return {"successes": int(ok.sum()), "diverged": int(div.sum()), "length_mean": float(first[ok].mean())}


def measure(monkeypatch, stand_in, **kw):
    monkeypatch.setattr(mjx_demos, "expert_rollout", stand_in)
    r = es.mjx_success("lift", kw.pop("episodes", 7), 1, SIGMA, steps=5, **kw)
    return {k: r[k] for k in ("successes", "diverged", "length_mean")}


def test_batching_keeps_the_episodes_and_drops_the_padding(monkeypatch):
    whole, batched = StandIn(), StandIn()
    assert measure(monkeypatch, whole) == expected(7) and whole.batches == [7]
    assert measure(monkeypatch, batched, batch=3) == expected(7)
    assert batched.batches == [3, 3, 3]  # one compiled shape; the last batch's two copies are dropped
    import jax

    monkeypatch.setattr(mjx_demos, "expert_rollout", StandIn())
    r = es.mjx_success("lift", 7, 1, SIGMA, steps=5, batch=3)
    first, div = outcome(jax.random.split(jax.random.PRNGKey(1), 7))
    assert r["first_success"] == first.tolist() and r["diverged_episodes"] == np.flatnonzero(div).tolist()


def test_an_interrupted_measurement_resumes_after_its_finished_batches(tmp_path, monkeypatch):
    part = es.mjx_partial_path(tmp_path, "lift", 7, 1, SIGMA, 5)
    with pytest.raises(KeyboardInterrupt):
        measure(monkeypatch, StandIn(fail_after=2), batch=3, partial=part)
    kept = json.loads(part.read_text())
    assert len(kept["first_success"]) == 6 and kept["seconds"] > 0
    rest = StandIn()
    assert measure(monkeypatch, rest, batch=3, partial=part) == expected(7)
    assert rest.batches == [3]  # only episode 6 was left
    assert len(json.loads(part.read_text())["diverged"]) == 7


def test_a_foreign_or_broken_record_is_refused_naming_the_field(tmp_path, monkeypatch):
    part = es.mjx_partial_path(tmp_path, "lift", 7, 1, SIGMA, 5)
    measure(monkeypatch, StandIn(), batch=4, partial=part)
    rec = json.loads(part.read_text())
    for field, value in (("seed", 2), ("diverged", "no"), ("first_success", [0] * 9)):
        part.write_text(json.dumps({**rec, field: value}))
        with pytest.raises(ConfigError, match=f"{part}: field '{field}'"):
            measure(monkeypatch, StandIn(), batch=4, partial=part)
    part.write_text("{not json")
    with pytest.raises(ConfigError, match="not JSON"):
        measure(monkeypatch, StandIn(), partial=part)


def test_the_command_writes_the_table_then_drops_its_partial_records(tmp_path, monkeypatch):
    monkeypatch.setattr(mjx_demos, "expert_rollout", StandIn())
    assert run_success(DemosSuccess(tasks=("lift",), simulator=("mjx",), episodes=5, out=tmp_path, batch=2)) == 0
    rows = json.loads((tmp_path / "success_mjx.json").read_text())
    assert rows[0]["successes"] == expected(5)["successes"] and rows[0]["episodes"] == 5
    assert "| lift | MJX | 5 |" in (tmp_path / "success_mjx.md").read_text()
    assert not list((tmp_path / ".partial").glob("*.json"))
    with pytest.raises(ConfigError, match="--batch"):
        run_success(DemosSuccess(tasks=("lift",), simulator=("mjx",), episodes=5, out=tmp_path, batch=-1))


@pytest.fixture
def restore_x64():
    with x64(False):  # the commands may turn it on; restored afterwards
        yield


def test_x64_is_part_of_the_measurement_and_its_table(tmp_path, monkeypatch, restore_x64):
    """--x64 runs the physics in float64 and the table says so; a float32 run's finished batches are not resumed by a
    float64 run (another partial file, and a record of the other precision is refused by field)."""
    part32 = es.mjx_partial_path(tmp_path, "lift", 7, 1, SIGMA, 5)
    with pytest.raises(KeyboardInterrupt):
        measure(monkeypatch, StandIn(fail_after=1), batch=3, partial=part32)
    monkeypatch.setattr(mjx_demos, "expert_rollout", StandIn())
    assert run_success(DemosSuccess(tasks=("lift",), simulator=("mjx",), episodes=5, out=tmp_path, batch=2,
                                    x64=True)) == 0  # fmt: skip
    assert "(x64 True)" in (tmp_path / "success_mjx.md").read_text()
    assert es.mjx_partial_path(tmp_path, "lift", 7, 1, SIGMA, 5, x64=True) != part32
    with pytest.raises(ConfigError, match=f"{part32}: field 'x64'"):
        measure(monkeypatch, StandIn(), batch=3, partial=part32)


def test_square_in_mjx_float32_gets_a_note_naming_the_flag(tmp_path, monkeypatch, capsys, restore_x64):
    monkeypatch.setattr(mjx_demos, "expert_rollout", StandIn())
    run_success(DemosSuccess(tasks=("nut_assembly_square",), simulator=("mjx",), episodes=2, out=tmp_path))
    assert "--x64" in capsys.readouterr().err
    run_success(DemosSuccess(tasks=("nut_assembly_square",), simulator=("mjx",), episodes=2, out=tmp_path, x64=True))
    assert "--x64" not in capsys.readouterr().err


def test_physics_preset_reaches_the_expert_and_names_its_tables(tmp_path, monkeypatch):
    """--physics fast measures the expert in MJX with that preset: its own tables (the reference's are not
    overwritten), its own partial records, and refused where no MJX runs."""
    stand_in = StandIn()
    monkeypatch.setattr(mjx_demos, "expert_rollout", stand_in)
    assert run_success(DemosSuccess(tasks=("lift",), simulator=("mjx",), episodes=5, out=tmp_path, physics="fast")) == 0
    assert stand_in.physics == ["fast"]
    table = (tmp_path / "success_mjx_fast.md").read_text()
    assert "| lift | MJX (fast physics) | 5 |" in table and "MJX physics fast" in table
    assert not (tmp_path / "success_mjx.md").exists()
    assert es.mjx_partial_path(tmp_path, "lift", 7, 1, SIGMA, 5, physics="fast") != es.mjx_partial_path(
        tmp_path, "lift", 7, 1, SIGMA, 5)  # fmt: skip
    with pytest.raises(ConfigError, match="--physics: 'fast' sets MJX's physics; --simulator robosuite"):
        run_success(DemosSuccess(tasks=("lift",), simulator=("robosuite",), episodes=5, out=tmp_path, physics="fast"))
