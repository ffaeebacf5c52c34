"""One table across sweep runs (ablations): ``python -m poir_mjx.cli compare results/cpu-ablate-* --out F``.

Each row is a (run, method): the run's config overrides and demonstration files, then the success
rate and Wilson interval per (task, sigma_init, sigma_action) cell, read from the run's cell
records made with the run's recorded config (each cell's config hash checked: stale cells are left out and
counted). Runs with the same grid, episodes and seeds
share their episode keys, so their rows are paired comparisons.

``--versus RUN:METHOD`` adds a second table: every other row's successes minus that reference row's, cell by cell
(matched by task, sigma_init and training seed; by sigma_action too where the reference has several), with the
two-sided Fisher exact p of one seed's pair, or the Cochran-Mantel-Haenszel p over the seeds (each seed a stratum),
and an "all cells" column over every stratum. Several ``RUN:METHOD`` references (e.g. one run per training seed)
act as one reference row made of all their cells; two of them with the same cell are refused. A difference drawn on
other starting states than the reference's (its episode keys differ: another seed, episode count or grid position)
is marked, since it is not a paired comparison.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from poir_mjx.atomic import atomic_write_text
from poir_mjx.core.config import ConfigError
from poir_mjx.eval.stats import wilson_interval


def _read_run(run: Path) -> tuple[dict, list[dict]]:
    """(recorded sweep config, the cell records made with it) of a run folder: a cell whose config hash is
    not the one this config gives now (a stale cell, left by an earlier config or version) is left out."""
    from poir_mjx.sweep.artifacts import cell_hash
    from poir_mjx.sweep.records import load_record, read_cell
    from poir_mjx.sweep.config import SweepConfig
    from poir_mjx.sweep.run_folder import upgrade_recorded

    cfg_path = run / "config.json"
    if not cfg_path.is_file():
        raise ConfigError(f"{cfg_path}: no such file (not a sweep run folder, or made before run folders recorded their config)")
    try:
        raw = json.loads(cfg_path.read_bytes().decode("utf-8"))
        if not isinstance(raw, dict):
            raise ConfigError(f"{cfg_path}: not a sweep config (expected a JSON object, got {type(raw).__name__})")
        raw = upgrade_recorded(raw)
        cfg = SweepConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in raw.items()})
    except ConfigError:
        raise
    except (OSError, ValueError, TypeError, RecursionError) as e:
        raise ConfigError(f"{cfg_path}: not a sweep config of this version ({type(e).__name__})") from None
    recs, stale = [], 0
    for f in sorted((run / "cells").rglob("*.json")):
        rec = load_record(f)
        if rec is None or "successes" not in rec:
            raise ConfigError(f"{f}: not a cell record")
        data = rec.get("data") if isinstance(rec.get("data"), dict) else {}
        task, method = rec.get("task", ""), rec.get("method", "")
        if task not in cfg.tasks or method not in cfg.methods:
            stale += 1
            continue
        chash = cell_hash(cfg, task, method, str(data.get("sha256", "")))
        if read_cell(f, chash, {"episodes": cfg.episodes, "task": task, "method": method}) is None:
            stale += 1
            continue
        recs.append(rec)
    if not recs:
        why = f"{stale} stale cell(s) only (made with another config or version); rerun the sweep" if stale else "run the sweep first"
        raise ConfigError(f"{run}/cells: no cell records of its config.json; {why}")
    if stale:
        print(f"{run}: {stale} stale cell record(s) left out (made with another config or version)")
    return raw, recs


def _key_slot(cfg: dict, rec: dict) -> tuple:
    """What a cell's episode keys are (rollout.evaluator.episode_keys: one split of the seed's key, the cells in the
    run's (sigma_init, sigma_action) grid order; jax's partitionable threefry makes key i independent of the split's
    size): the seed, the index of the cell's first episode and the episode count."""
    from poir_mjx.sweep.config import SweepConfig

    sis, sas = (cfg.get(f, SweepConfig.__dataclass_fields__[f].default) for f in ("sigma_init", "sigma_action"))
    grid = [(si, sa) for si in sis for sa in sas]
    pos = next((j for j, (si, sa) in enumerate(grid) if math.isclose(si, rec["sigma_init"]) and
                math.isclose(sa, rec["sigma_action"])), None)  # fmt: skip
    return rec.get("seed", 0), None if pos is None else pos * rec["episodes"], rec["episodes"]


def compare(runs: list[Path], versus: tuple[tuple[Path, str], ...] = (), methods: tuple[str, ...] = (),
            read: dict | None = None) -> str:  # fmt: skip
    """The table (and, with `versus`, the differences against those (run, method) rows taken as one reference);
    `methods`: only these methods' rows (and the reference's)."""
    rows, cols, strata = [], [], {}
    for run in runs:
        cfg, recs = read[run] if read is not None else _read_run(run)
        keep = set(methods) | {m for r, m in versus if r.name == run.name}
        recs = [r for r in recs if not methods or r["method"] in keep]
        for rec in recs:
            strata.setdefault((run.name, rec["method"]), []).append(
                ((rec["task"], rec["sigma_init"], rec["sigma_action"], rec.get("seed", 0)), rec["successes"],
                 rec["episodes"], _key_slot(cfg, rec), _labels(rec)))  # fmt: skip
        by_method: dict[str, dict] = {}
        for rec in recs:
            col = (rec["task"], rec["sigma_init"], rec["sigma_action"])
            if col not in cols:
                cols.append(col)
            cell = by_method.setdefault(rec["method"], {}).setdefault(col, [0, 0])
            cell[0] += rec["successes"]
            cell[1] += rec["episodes"]
        changed = {**cfg.get("overrides", {}), **{f"demo_files.{t}": f for t, f in cfg.get("demo_files", {}).items()}}
        overrides = ", ".join(f"{k}={v}" for k, v in sorted(changed.items())) or "-"
        for method, cells in by_method.items():
            rows.append((run.name, overrides, method, cells))
    cols.sort()
    head = "| run | overrides | method | " + " | ".join(f"{t} σ_init {si:g}" + (f" σ_act {sa:g}" if sa else "") for t, si, sa in cols) + " |"
    lines = [head, "|---|---|---|" + "---|" * len(cols)]
    for name, overrides, method, cells in rows:
        out = []
        for col in cols:
            if col not in cells:
                out.append("-")
                continue
            k, n = cells[col]
            lo, hi = wilson_interval(k, n)
            out.append(f"{k}/{n} = {k / n:.2f} [{lo:.2f}, {hi:.2f}]")
        lines.append(f"| {name} | {overrides} | {method} | " + " | ".join(out) + " |")
    text = "\n".join(lines) + "\n"
    if versus:
        text += _versus(versus, rows, cols, strata)
    return text


def _reference(versus: tuple[tuple[Path, str], ...], strata: dict) -> list:
    """The cells of every reference row together (each cell from one reference only)."""
    ref, owner = [], {}
    for run, method in versus:
        cells = strata.get((run.name, method))
        if cells is None:
            have = sorted(f"{r}:{m}" for r, m in strata)
            raise ConfigError(f"--versus: no row {run.name}:{method} among the runs compared (rows: {', '.join(have)})")
        for cell in cells:
            task, si, sa, seed = cell[0]
            first = owner.setdefault((task, round(si, 9), round(sa, 9), seed), f"{run.name}:{method}")
            if first != f"{run.name}:{method}":
                raise ConfigError(f"--versus: {first} and {run.name}:{method} both have {task} sigma_init {si:g} "
                                  f"sigma_action {sa:g} seed {seed}; give one reference per cell (e.g. one per training seed)")  # fmt: skip
            ref.append(cell)
    return ref


def _versus(versus: tuple[tuple[Path, str], ...], rows: list, cols: list, strata: dict) -> str:
    from poir_mjx.eval.episodes import agreement_p_value
    from poir_mjx.eval.stats import pooled_p_value

    ref, ref_name = _reference(versus, strata), " + ".join(f"{r.name}:{m}" for r, m in versus)
    refs = {(r.name, m) for r, m in versus}

    def match(task, si, sa, seed):
        same = [c for c in ref if c[0][0] == task and math.isclose(c[0][1], si) and c[0][3] == seed]
        exact = [c for c in same if math.isclose(c[0][2], sa)]
        return exact[0] if exact else (same[0] if len(same) == 1 else None)

    others = [(name, method) for name, _, method, _ in rows if (name, method) not in refs]
    overrides_of = {name: overrides for name, overrides, _, _ in rows}
    cols = [c for c in cols if any((c[0], c[1], c[2]) == key[:3] for row in others for key, *_ in strata[row])]
    labels = [f"{t} σ_init {si:g}" + (f" σ_act {sa:g}" if sa else "") for t, si, sa in cols]
    head = f"| run | method | {' | '.join(labels)} | all cells |"
    lines = ["", f"Versus {ref_name}: difference in successes, two-sided Fisher exact p (one seed) or "
             "Cochran-Mantel-Haenszel p over the training seeds; all cells: over every (cell, seed) both have; all runs: "
             "a method's rows of several runs with the same overrides and action noise, each of other training seeds, together.", "",
             head, "|---|---|" + "---|" * (len(cols) + 1)]  # fmt: skip
    def cells(entries: list) -> tuple[list[str], bool]:
        out, every, unpaired = [], [], False
        for col in cols:
            pairs, mark = [], ""
            for (task, si, sa, seed), k, n, slot, _ in entries:
                r = match(task, si, sa, seed) if (task, si, sa) == col else None
                if r is not None:
                    pairs.append((k, n, r[1], r[2]))
                    mark = mark or ("" if slot == r[3] else " ‡")
            if not pairs:
                out.append("-")
                continue
            unpaired |= bool(mark)
            every += pairs
            d = sum(k1 - k2 for k1, _, k2, _ in pairs)
            p = agreement_p_value(*pairs[0]) if len(pairs) == 1 else pooled_p_value(pairs)
            out.append(f"{d:+d} (p {p:.2g}){mark}")
        total = sum(k1 - k2 for k1, _, k2, _ in every)
        out.append(f"{total:+d} (p {pooled_p_value(every):.2g})" if len(every) > 1 else "-")
        return out, unpaired

    unpaired, runs_of = False, {}
    for name, method in others:
        out, mark = cells(strata[(name, method)])
        unpaired |= mark
        # pooled only with runs of the same overrides and action noise (sigma_init grids may differ), one per seed
        same = (method, overrides_of[name], frozenset((key[0], key[2]) for key, *_ in strata[(name, method)]))
        runs_of.setdefault(same, []).append(name)
        lines.append(f"| {name} | {method} | " + " | ".join(out) + " |")
    for (method, _, _), names in runs_of.items():  # a method in several such runs: every stratum
        seeds = [{key[3] for key, *_ in strata[(name, method)]} for name in names]
        if len(names) > 1 and len(set().union(*seeds)) == sum(map(len, seeds)):  # no training seed twice
            out, _ = cells([e for name in names for e in strata[(name, method)]])
            lines.append(f"| all {len(names)} runs | {method} | " + " | ".join(out) + " |")
    lines += _transitions(others, strata, match, ref_name)
    if unpaired:
        lines += ["", "‡ other starting states than the reference's (other episode keys): not a paired comparison."]
    return "\n".join(lines) + "\n"


def _labels(rec: dict) -> list[str] | None:
    """A cell record's per-episode outcomes (eval/outcomes.py), if it has a well-formed list of them."""
    from poir_mjx.eval.outcomes import OUTCOMES

    labels = rec.get("episode_outcomes")
    ok = isinstance(labels, list) and len(labels) == rec["episodes"] and all(x in OUTCOMES for x in labels)
    return labels if ok else None


def _transitions(others: list, strata: dict, match, ref_name: str) -> list[str]:
    """Episode by episode on the same starts, where both cells record how each episode ended: per row, how the
    reference's episodes of each outcome ended under the row's method (markdown lines; none without labels)."""
    from collections import Counter

    from poir_mjx.eval.outcomes import OUTCOMES

    table = []
    for name, method in others:
        moves = Counter()
        for (task, si, sa, seed), _, _, slot, labels in strata[(name, method)]:
            r = match(task, si, sa, seed)
            if labels is not None and r is not None and r[4] is not None and slot == r[3]:
                moves.update(zip(r[4], labels))
        for start in OUTCOMES:
            row = [moves[(start, end)] for end in OUTCOMES]
            if sum(row):
                table.append(f"| {name} | {method} | {start} | {sum(row)} | " + " | ".join(map(str, row)) + " |")
    if not table:
        return []
    return ["", f"Episode by episode on the same starts (cells that record how each episode ended): the {ref_name} "
            "episodes of each outcome, and how the same episodes ended under the row's method.", "",
            f"| run | method | {ref_name} | episodes | " + " | ".join(OUTCOMES) + " |",
            "|---|---|---|---|" + "---|" * len(OUTCOMES), *table]  # fmt: skip


def _provenance(read: dict) -> str:
    """The command and, per run, where its cells come from (simulator, machine, expert data's digest)."""
    from poir_mjx.versions import command_line

    lines = [f"Command: `{command_line()}`.", ""]
    for run, (_, recs) in read.items():
        where = sorted({(str(r.get("simulator", "MJX")), str(r.get("machine", "?")),
                         str((r.get("data") or {}).get("sha256", "?")), _stack(r.get("stack"))) for r in recs})  # fmt: skip
        lines.append(f"- {run.name}: " + "; ".join(f"{sim}, {mach}, demos sha256 {sha}{st}"
                                                    for sim, mach, sha, st in where) + _agents(recs))  # fmt: skip
    return "\n".join(lines + _one_name_two_agents(read)) + "\n\n"


def _agents(recs: list[dict]) -> str:
    """The checkpoints a run's cells ran, with their file digests where the records carry them."""
    named = sorted({(Path(str(r["checkpoint"])).name, str(r.get("checkpoint_sha256", "not recorded")))
                    for r in recs if r.get("checkpoint")})  # fmt: skip
    return "; agents " + ", ".join(f"{n} (sha256 {d})" for n, d in named) if named else ""


def _one_name_two_agents(read: dict) -> list[str]:
    """A warning for each checkpoint name whose cells, across the runs, ran files with different digests: their
    episodes are not the same agent's, whatever the name says (an agent retrained from the same key may differ)."""
    seen: dict[str, dict[str, dict[str, None]]] = {}  # name -> digest -> the runs (an ordered set)
    for run, (_, recs) in read.items():
        for r in recs:
            if r.get("checkpoint") and r.get("checkpoint_sha256"):
                digests = seen.setdefault(Path(str(r["checkpoint"])).name, {})
                digests.setdefault(str(r["checkpoint_sha256"]), {})[run.name] = None
    return [f"- **{name}: different agents under one name**, " + "; ".join(f"sha256 {d} in {', '.join(rs)}"
                                                                          for d, rs in digests.items())
            for name, digests in seen.items() if len(digests) > 1]  # fmt: skip


def _stack(stack) -> str:
    return "" if not isinstance(stack, dict) else ", " + ", ".join(f"{k} {v}" for k, v in stack.items())


def parse_versus(text: str) -> tuple[Path, str]:
    """``RUN:METHOD`` (the method after the last colon) as (run folder, method)."""
    run, sep, method = text.rpartition(":")
    if not sep or not run or not method:
        raise ConfigError(f"--versus: {text!r} is not RUN:METHOD (e.g. results/cpu-prior:EBC)")
    return Path(run), method


def main(runs: list[Path], out: Path | None, versus: tuple[str, ...] = (), methods: tuple[str, ...] = ()) -> int:
    ref = tuple(parse_versus(v) for v in versus)
    for run, _ in ref:
        if run.resolve() not in [r.resolve() for r in runs]:
            runs = [*runs, run]
    read = {run: _read_run(run) for run in runs}  # each run folder read (and its stale cells counted) once
    text = _provenance(read) + compare(runs, ref, methods, read)
    print(text, end="")
    if out is not None:
        atomic_write_text(out, text)
        print(f"wrote {out}")
    return 0
