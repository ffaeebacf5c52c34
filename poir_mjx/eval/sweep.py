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
A cell whose record exists with the same config hash is never recomputed, so a sweep killed at
any moment and started again with the same command finishes with the same tables.

This module runs the cells; the config is ``sweep_config.py``, the data, checkpoints and cell
records ``artifacts.py``, the tables ``report.py``, the episodes (MJX or robosuite) ``episodes.py``.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import time
from pathlib import Path

import jax
import numpy as np

from poir_mjx.atomic import atomic_write_text
from poir_mjx.core.agent import POIR
from poir_mjx.core.config import to_dict
from poir_mjx.envs.env import make_env, make_params
from poir_mjx.eval import run_folder
from poir_mjx.eval.artifacts import cell_hash, cell_path, demos_for, read_cell, train_or_load
from poir_mjx.eval.episodes import run_episodes
from poir_mjx.eval.methods import get_method
from poir_mjx.eval.report import write_tables
from poir_mjx.eval.evaluator import episode_keys
from poir_mjx.eval.run_folder import check_run_name
from poir_mjx.eval.stats import wilson_interval
from poir_mjx.eval.sweep_config import SweepConfig, load_sweep_config
from poir_mjx.versions import simulator_line

__all__ = ["SweepConfig", "load_sweep_config", "run_sweep"]


def run_sweep(cfg: SweepConfig, results_root: Path = Path("results"), data_dir: Path = Path("data/demos"),
              ckpt_dir: Path = Path("checkpoints"), progress: bool = True, replace_config: bool = False) -> Path:  # fmt: skip
    from tqdm import tqdm

    out = results_root / check_run_name(cfg.name, "sweep config")
    run_folder.prepare(out, dataclasses.asdict(cfg), replace_config)  # before any work: writable, one config
    grid = [(si, sa) for si in cfg.sigma_init for sa in cfg.sigma_action]
    cells = [(t, m, s) for t in cfg.tasks for m in cfg.methods for s in cfg.seeds]
    total_eps = len(cells) * len(grid) * cfg.episodes
    bar = tqdm(total=total_eps, desc=f"sweep {cfg.name}", unit="ep", disable=not progress)
    t_start, done_now = time.perf_counter(), 0
    demos = {task: demos_for(cfg, task, data_dir, progress) for task in cfg.tasks}  # (transitions, provenance)
    digests = {task: prov["sha256"] for task, (_, prov) in demos.items()}
    for task, mname, seed in cells:
        method = get_method(mname)
        chash = cell_hash(cfg, task, mname, digests[task])
        paths = [cell_path(out, task, mname, si, sa, seed) for si, sa in grid]
        if all(read_cell(p, chash) for p in paths):
            bar.update(len(grid) * cfg.episodes)
            continue
        tr, prov = demos[task]
        agent, params, ckpt = train_or_load(method, cfg, task, seed, tr, prov, ckpt_dir, progress)
        si = np.repeat([g[0] for g in grid], cfg.episodes)
        sa = np.repeat([g[1] for g in grid], cfg.episodes)
        keys = episode_keys(seed, len(si))  # one key per episode
        common = {"task": task, "method": mname, "seed": seed, "episodes": cfg.episodes, "max_steps": cfg.max_steps,
                  "config_hash": chash, "checkpoint": str(ckpt), "data": prov,
                  "device": f"{jax.devices()[0].platform} x{jax.device_count()}", "x64": bool(jax.config.jax_enable_x64),
                  "simulator": simulator_line(cfg.simulator)}  # fmt: skip
        if method.online:
            # Each noise cell is its own deployment environment: fine-tune there, evaluate on the
            # cell's own episode keys (the offline cell's keys: a paired comparison).
            offline = (tr.obs, tr.actions, tr.next_obs)
            for j, ((s_i, s_a), path) in enumerate(zip(grid, paths)):
                if read_cell(path, chash):
                    bar.update(cfg.episodes)
                    continue
                sl = slice(j * cfg.episodes, (j + 1) * cfg.episodes)
                t0 = time.perf_counter()
                slug = mname.replace(" ", "_")
                ckpt_path = ckpt_dir / task / "online" / f"{slug}-si={s_i:g}_sa={s_a:g}_seed={seed}-{chash}.ckpt"
                res = run_online_cell(cfg, task, agent, params, offline, s_i, s_a, seed, keys[sl], ckpt_path,
                                      chash, progress)  # fmt: skip
                final = res.curve[-1]
                rec = _cell_record(common, s_i, s_a, final["successes"], final["diverged"], None,
                                   time.perf_counter() - t0)  # fmt: skip
                rec.update(curve=res.curve, rounds=res.rounds, online=to_dict(agent.config.online),
                           resumed_from_round=res.resumed_from_round, online_checkpoint=str(ckpt_path))  # fmt: skip
                atomic_write_text(path, json.dumps(rec, indent=2) + "\n")
                done_now += cfg.episodes
                bar.update(cfg.episodes)
            continue
        t0 = time.perf_counter()
        res = run_episodes(cfg.simulator, task, method, agent, params, keys, si, sa, cfg.max_steps, cfg.workers,
                           progress)  # fmt: skip
        wall = time.perf_counter() - t0
        for j, ((s_i, s_a), path) in enumerate(zip(grid, paths)):
            sl = slice(j * cfg.episodes, (j + 1) * cfg.episodes)
            first = res["first_success"][sl]
            rec = _cell_record(common, s_i, s_a, int((first >= 0).sum()), int(res["diverged"][sl].sum()),
                               np.where(first >= 0, first, cfg.max_steps), wall / len(grid))  # fmt: skip
            atomic_write_text(path, json.dumps(rec, indent=2) + "\n")
        done_now += len(si)
        bar.update(len(si))
        bar.set_postfix(eps_per_s=f"{done_now / (time.perf_counter() - t_start):.2f}")
    bar.close()
    write_tables(cfg, out, digests)
    return out


def _cell_record(common: dict, si: float, sa: float, k: int, diverged: int, lengths, wall: float) -> dict:
    n = common["episodes"]
    lo, hi = wilson_interval(k, n)
    rec = {**common, "sigma_init": si, "sigma_action": sa, "successes": k, "success_rate": k / n, "wilson95": [lo, hi],
           "diverged": diverged, "wall_s": wall}  # fmt: skip
    if lengths is not None:
        rec["mean_episode_length"] = float(np.mean(lengths))
    return rec


def run_online_cell(cfg: SweepConfig, task: str, agent: POIR, params, offline: tuple, si: float, sa: float,
                    seed: int, eval_keys, ckpt_path: Path, chash: str, progress: bool):  # fmt: skip
    """Online fine-tuning in the cell's environment (resumes from `ckpt_path`), evaluated on `eval_keys`.

    offline: the expert transitions (obs, actions, next_obs) the agent was trained on.
    """
    trainer = _online_trainer(task, agent, cfg.max_steps)
    key = jax.random.PRNGKey(seed)
    for x in (2, round(si * 1e6), round(sa * 1e6)):  # the cell's own stream: collection and training keys
        key = jax.random.fold_in(key, x)
    return trainer.run(params, offline, make_params(si, sa), eval_keys, key,
                       checkpoint_path=ckpt_path, config_hash=chash, progress=progress)  # fmt: skip


@functools.lru_cache(maxsize=None)
def _online_trainer(task: str, agent: POIR, steps: int):
    from poir_mjx.online.loop import OnlineTrainer

    return OnlineTrainer(make_env(task), agent, steps)
