"""Noise sweeps: tasks x methods x (sigma_init, sigma_action) grid x seeds, resumable, atomic.

    python -m poir_mjx.cli sweep --config experiments/cpu-small.json

Layout of ``results/<name>/``:
    config.json                                         the sweep config the folder was made with
    cells/<task>/<method>/si=<s>_sa=<a>_seed=<k>.json   one record per cell (written atomically)
    <task>.md, <task>.csv, <task>.png                   success rate versus noise
    <task>-online.png                                   learning curves of the online methods
    summary.md                                          all tables, data provenance, config
An online method ("POIR-<reward> online") fine-tunes its world model in each cell's perturbed
environment (poir_mjx/online), checkpointing after every round under
checkpoints/<task>/online/; its cell holds the success after fine-tuning and the learning curve.
A baseline (DAC, ValueDICE, SQIL, PPO+DRIL) trains from scratch in each cell's perturbed MJX
environment (poir_mjx/baselines), checkpointing under checkpoints/<task>/baselines/; its cell holds
the trained policy's success (in the sweep's simulator) and its learning curve (in MJX).
A cell whose record exists with the same config hash is never recomputed, so a sweep killed at
any moment and started again with the same command finishes with the same tables. The tables are
rewritten from the cells finished so far ("-" for the others) after every (task, method, seed) and
every robosuite cell.

This module walks the plan (``plan.py``: the grid, config hashes, cell paths, the reader of cell records); the
cell runners are ``cells.py``, the config ``config.py``, the data, checkpoints and cell records ``artifacts.py``,
the tables ``report.py`` and ``curves.py``, the episodes (MJX or robosuite) ``poir_mjx/eval/episodes.py``.
"""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import jax

from poir_mjx.atomic import atomic_write_text
from poir_mjx.compat import x64_enabled
from poir_mjx.envs.tasks import float32_square_note
from poir_mjx.sweep import run_folder
from poir_mjx.folder_lock import locked
from poir_mjx.outputs import check_folder, check_run_folder
from poir_mjx.sweep.artifacts import cell_path, checkpoint_digest, demos_for, train_or_load
from poir_mjx.sweep.cells import CellBatch, run_baseline_cells, run_offline_cells, run_online_cells
from poir_mjx.eval.methods import get_method
from poir_mjx.sweep.report import write_tables
from poir_mjx.rollout.evaluator import episode_keys
from poir_mjx.sweep.run_folder import check_run_name
from poir_mjx.core.config import ConfigError
from poir_mjx.sweep.config import SweepConfig, base_config, load_sweep_config
from poir_mjx.sweep.plan import SweepPlan
from poir_mjx.versions import machine_line, simulator_line, stack, stack_line

__all__ = ["SweepConfig", "load_sweep_config", "run_sweep"]


def run_sweep(cfg: SweepConfig, results_root: Path = Path("results"), data_dir: Path = Path("data/demos"),
              ckpt_dir: Path = Path("checkpoints"), progress: bool = True, replace_config: bool = False) -> Path:  # fmt: skip
    out = results_root / check_run_name(cfg.name, "sweep config")
    check_run_folder(out, run_files(cfg, out), "sweep's run folder")  # not published, no link out, no dir as a file
    with locked(out):  # one process per run folder (a second one: one line, exit status 2)
        return _run(cfg, out, data_dir, ckpt_dir, progress, replace_config)


def run_files(cfg: SweepConfig, out: Path) -> list[Path]:
    """Every file the sweep writes in its run folder (its cell records, tables and plots)."""
    files = [out / "config.json", out / "summary.md"]
    for task in cfg.tasks:
        files += [out / f"{task}{ext}" for ext in (".md", ".csv", ".png", "-online.png", "-baselines.png")]
        files += [cell_path(out, task, m, si, sa, seed) for m in cfg.methods for si in cfg.sigma_init
                  for sa in cfg.sigma_action for seed in cfg.seeds]  # fmt: skip
    return files


def _run(cfg: SweepConfig, out: Path, data_dir: Path, ckpt_dir: Path, progress: bool, replace_config: bool) -> Path:
    from tqdm import tqdm

    config_text = run_folder.check_config(out, dataclasses.asdict(cfg), replace_config,
                                          defaults=dataclasses.asdict(SweepConfig(name=cfg.name)))  # fmt: skip

    def record_config() -> None:  # once the run has trained or reused an agent: a refused run leaves no config.json
        if not (out / "config.json").is_file() or (out / "config.json").read_text() != config_text:
            atomic_write_text(out / "config.json", config_text)

    for task in cfg.tasks:  # every folder the run will write, before any work (nothing made yet)
        for mname in cfg.methods:
            check_folder(out / "cells" / task / mname, "cell folder")
        check_folder(Path(ckpt_dir) / task, "checkpoints folder")
    if progress:  # once, what runs (the known import-time warnings are silenced: poir_mjx/quiet.py)
        print(f"sweep {cfg.name}: evaluation in {simulator_line(cfg.simulator)}; {stack_line()}; {machine_line()}",
              file=sys.stderr, flush=True)  # fmt: skip
        note = float32_square_note(cfg.tasks, (cfg.simulator, cfg.demo_simulator), cfg.x64 or x64_enabled(),
                                   '"x64": true in the sweep config')  # fmt: skip
        if note:
            print(note, file=sys.stderr, flush=True)
    demos = {task: demos_for(cfg, task, data_dir, progress) for task in cfg.tasks}  # (transitions, provenance)
    for task, (tr, _) in demos.items():  # before any training: enough demos for every method's batch
        for mname in (m for m in cfg.methods if not get_method(m).is_baseline):
            batch_size = get_method(mname).training_config(base_config(cfg)).train.batch_size
            if tr.num_transitions < batch_size:
                raise ConfigError(f"{tr.path}: {tr.num_transitions} expert transitions, fewer than {mname}'s "
                                  f"train.batch_size {batch_size}")  # fmt: skip
    plan = SweepPlan.build(cfg, out, {task: prov["sha256"] for task, (_, prov) in demos.items()})
    note = run_folder.demo_note(cfg.name, out, plan.digests)
    if note and progress:
        print(note, file=sys.stderr, flush=True)
    grid = plan.grid
    bar = tqdm(total=len(plan.runs()) * len(grid) * cfg.episodes, desc=f"sweep {cfg.name}", unit="ep",
               disable=not progress)  # fmt: skip
    t_start, done_now = time.perf_counter(), 0

    def evaluated(n: int) -> None:  # after each offline evaluation call (a robosuite cell, or MJX's batch)
        nonlocal done_now
        done_now += n
        bar.update(n)
        bar.set_postfix(eps_per_s=f"{done_now / (time.perf_counter() - t_start):.2f}")
        write_tables(plan)

    for task, mname, seed in plan.runs():
        method = get_method(mname)
        cells = plan.cells(task, mname, seed)
        chash, paths = cells[0].config_hash, [c.path for c in cells]
        if all(c.record() for c in cells):
            bar.update(len(grid) * cfg.episodes)
            continue
        tr, prov = demos[task]
        common = {"task": task, "method": mname, "seed": seed, "episodes": cfg.episodes, "max_steps": cfg.max_steps,
                  "config_hash": chash, "data": prov,
                  "device": f"{jax.devices()[0].platform} x{jax.device_count()}", "x64": bool(jax.config.jax_enable_x64),
                  "simulator": simulator_line(cfg.simulator), "machine": machine_line(), "stack": stack()}  # fmt: skip
        batch = CellBatch(cfg, task, mname, seed, grid, paths, episode_keys(seed, len(grid) * cfg.episodes), chash,
                          common)  # fmt: skip
        if method.is_baseline:
            record_config()
            run_baseline_cells(batch, tr, ckpt_dir, progress, bar.update)
            write_tables(plan)  # the finished cells are readable while a long sweep runs
            continue
        agent, params, ckpt = train_or_load(method, cfg, task, seed, tr, prov, ckpt_dir, progress)
        record_config()
        batch = dataclasses.replace(batch, common={**common, "checkpoint": str(ckpt),
                                                   "checkpoint_sha256": checkpoint_digest(ckpt)})
        if method.online:
            run_online_cells(batch, agent, params, (tr.obs, tr.actions, tr.next_obs), ckpt_dir, progress, bar.update)
            write_tables(plan)
            continue
        run_offline_cells(batch, method, agent, params, progress, evaluated)
    bar.close()
    record_config()
    write_tables(plan)
    return out
