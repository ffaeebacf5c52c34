"""The cell runners of a sweep: offline methods (the missing noise cells in one MJX batch, or cell by cell in
robosuite), online fine-tuning and the baselines (one training run per noise cell, resumable). Each writes its cells'
records atomically."""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.cached import builder
from poir_mjx.atomic import atomic_write_text
from poir_mjx.core.agent import POIR
from poir_mjx.core.config import to_dict
from poir_mjx.envs.env import make_env, make_params
from poir_mjx.eval import robosuite_eval
from poir_mjx.sweep.records import read_cell
from poir_mjx.eval.episodes import run_episodes
from poir_mjx.eval.outcomes import summary
from poir_mjx.eval.stats import wilson_interval
from poir_mjx.sweep.config import SweepConfig, baseline_config


@dataclasses.dataclass(frozen=True)
class CellBatch:
    """One (task, method, seed) of a sweep: its noise grid, the cell files, the keys and what every record shares."""

    cfg: SweepConfig
    task: str
    method: str
    seed: int
    grid: list[tuple[float, float]]  # (sigma_init, sigma_action) per cell
    paths: list[Path]  # the cell records, in grid order
    keys: jax.Array  # one key per episode: cell j uses keys[j * episodes: (j + 1) * episodes]
    chash: str
    common: dict  # fields every record of the batch carries

    def cell_keys(self, j: int) -> jax.Array:
        e = self.cfg.episodes
        return self.keys[j * e:(j + 1) * e]

    def cell_key(self, j: int) -> jax.Array:
        """The cell's own training stream (collection and updates), distinct from its evaluation keys."""
        si, sa = self.grid[j]
        key = jax.random.PRNGKey(self.seed)
        for x in (2, round(si * 1e6), round(sa * 1e6)):
            key = jax.random.fold_in(key, x)
        return key

    def record(self, j: int, successes: int, diverged: int, lengths, wall: float) -> dict:
        n = self.cfg.episodes
        lo, hi = wilson_interval(successes, n)
        si, sa = self.grid[j]
        rec = {**self.common, "episodes": n, "sigma_init": si, "sigma_action": sa, "successes": successes,
               "success_rate": successes / n, "wilson95": [lo, hi], "diverged": diverged, "wall_s": wall}  # fmt: skip
        if lengths is not None:
            rec["mean_episode_length"] = float(np.mean(lengths))
        return rec

    def done(self, j: int) -> dict | None:
        """Cell j's record, if made with this config (its schema checked: ``records.read_cell``)."""
        si, sa = self.grid[j]
        return read_cell(self.paths[j], self.chash, {"episodes": self.cfg.episodes, "task": self.task,
                                                     "method": self.method, "seed": self.seed, "sigma_init": si,
                                                     "sigma_action": sa})  # fmt: skip

    def write(self, j: int, rec: dict) -> None:
        atomic_write_text(self.paths[j], json.dumps(rec, indent=2) + "\n")


def run_offline_cells(b: CellBatch, method, agent: POIR, params, progress: bool,
                      on_cells: Callable[[int], None]) -> None:  # fmt: skip
    """The batch's noise cells that have no record yet. MJX: all of them in one evaluation call (one compiled
    batch). robosuite: one call per cell, each cell's record written as soon as its episodes end, so a stopped run
    keeps every finished cell (a PickPlaceCan cell of POIR-DRIL takes about 7 minutes on the 2-core CPU, of POIR-L2
    about 45). on_cells(episodes) after each call's records are written."""
    todo = [j for j in range(len(b.grid)) if not b.done(j)]
    for js in [todo] if b.cfg.simulator == "mjx" else [[j] for j in todo]:
        if js:
            on_cells(_evaluate_cells(b, method, agent, params, js, progress))


def _evaluate_cells(b: CellBatch, method, agent: POIR, params, js: list[int], progress: bool) -> int:
    cfg, e = b.cfg, b.cfg.episodes
    keys = jnp.concatenate([b.cell_keys(j) for j in js])
    si = np.repeat([b.grid[j][0] for j in js], e)
    sa = np.repeat([b.grid[j][1] for j in js], e)
    t0 = time.perf_counter()
    res = run_episodes(cfg.simulator, b.task, method, agent, params, keys, si, sa, cfg.max_steps, cfg.workers,
                       progress, cfg.observation, cfg.physics)  # fmt: skip
    wall = time.perf_counter() - t0
    for i, j in enumerate(js):
        sl = slice(i * e, (i + 1) * e)
        first = res["first_success"][sl]
        rec = b.record(j, int((first >= 0).sum()), int(res["diverged"][sl].sum()),
                       np.where(first >= 0, first, cfg.max_steps), wall / len(js))  # fmt: skip
        if "outcome" in res:  # robosuite on the low-dim observation: how each episode ended (eval/outcomes.py)
            rec["outcomes"] = summary(res["outcome"][sl], res["moved_object"][sl])
            rec["episode_outcomes"] = res["outcome"][sl]
        b.write(j, rec)
    return len(si)


def run_online_cells(b: CellBatch, agent: POIR, params, offline: tuple, ckpt_dir: Path, progress: bool,
                     on_cell: Callable[[int], None]) -> None:  # fmt: skip
    """Each noise cell is its own deployment environment: fine-tune there (resumable), evaluate on the cell's own
    episode keys (the offline cell's keys: a paired comparison). offline: the expert (obs, actions, next_obs)."""
    where = agent.config.online.simulator
    trainer = _online_trainer(b.task, agent, b.cfg.max_steps, b.cfg.simulator if where == "sweep" else where,
                              b.cfg.simulator, b.cfg.workers, b.cfg.observation, b.cfg.physics)  # fmt: skip
    for j, (s_i, s_a) in enumerate(b.grid):
        if b.done(j):
            on_cell(b.cfg.episodes)
            continue
        t0 = time.perf_counter()
        ckpt = ckpt_dir / b.task / "online" / f"{_slug(b.method)}-{_cell_slug(b, j)}-{b.chash}.ckpt"
        res = trainer.run(params, offline, make_params(s_i, s_a), b.cell_keys(j), b.cell_key(j),
                          checkpoint_path=ckpt, config_hash=b.chash, progress=progress)  # fmt: skip
        final = res.curve[-1]
        rec = b.record(j, final["successes"], final["diverged"], None, time.perf_counter() - t0)
        rec.update(curve=res.curve, rounds=res.rounds, online=to_dict(agent.config.online),
                   resumed_from_round=res.resumed_from_round, online_checkpoint=str(ckpt))  # fmt: skip
        b.write(j, rec)
        on_cell(b.cfg.episodes)


def run_baseline_cells(b: CellBatch, tr, ckpt_dir: Path, progress: bool, on_cell: Callable[[int], None]) -> None:
    """Train the baseline in each noise cell's perturbed MJX environment (resumable), learning curve in MJX on the
    cell's episode keys; the cell's success is the trained policy on those keys in the sweep's simulator."""
    from poir_mjx.baselines.registry import get_baseline
    from poir_mjx.baselines.run import expert_data, train_baseline

    cfg = b.cfg
    bcfg = baseline_config(cfg, b.method)
    env = make_env(b.task, observation=cfg.observation, physics=cfg.physics)
    baseline = get_baseline(b.method)
    learner = baseline.make(env, bcfg, tr.obs.shape[1], tr.actions.shape[1])
    total, every = baseline.schedule(bcfg)
    expert = expert_data(tr)
    for j, (s_i, s_a) in enumerate(b.grid):
        if b.done(j):
            on_cell(cfg.episodes)
            continue
        t0 = time.perf_counter()
        ckpt = ckpt_dir / b.task / "baselines" / f"{_slug(b.method)}-{_cell_slug(b, j)}-{b.chash}.ckpt"
        res = train_baseline(learner, env, expert, make_params(s_i, s_a), b.cell_keys(j), cfg.max_steps,
                             b.cell_key(j), total_env_steps=total, eval_every=every,
                             env_steps_per_iteration=learner.env_steps_per_iteration, checkpoint_path=ckpt,
                             config_hash=b.chash, progress=progress)  # fmt: skip
        if cfg.simulator == "mjx":
            final = res.curve[-1]
            k, div, lengths = final["successes"], final["diverged"], None
        else:
            out = robosuite_eval.evaluate(b.task, learner.policy_fn(), res.policy_params, b.cell_keys(j),
                                          np.full(cfg.episodes, s_i), np.full(cfg.episodes, s_a), cfg.max_steps,
                                          cfg.workers, progress=progress, observation=cfg.observation)  # fmt: skip
            first = out["first_success"]
            k, div, lengths = int((first >= 0).sum()), int(out["diverged"].sum()), np.where(first >= 0, first, cfg.max_steps)
        rec = b.record(j, k, div, lengths, time.perf_counter() - t0)
        rec.update(curve=res.curve, baseline=to_dict(bcfg), resumed_from_env_steps=res.resumed_from_env_steps,
                   baseline_checkpoint=str(ckpt), curve_simulator="MJX (training environment)")  # fmt: skip
        b.write(j, rec)
        on_cell(cfg.episodes)


def _slug(method: str) -> str:
    return method.replace(" ", "_").replace("+", "-")


def _cell_slug(b: CellBatch, j: int) -> str:
    si, sa = b.grid[j]
    return f"si={si:g}_sa={sa:g}_seed={b.seed}"


@builder
def _online_trainer(task: str, agent: POIR, steps: int, collect_in: str, evaluate_in: str, workers: int,
                    observation: str, physics: str):  # fmt: skip
    from poir_mjx.online.loop import OnlineTrainer

    return OnlineTrainer(make_env(task, observation=observation, physics=physics), agent, steps, task, collect_in, evaluate_in, workers,
                         observation)  # fmt: skip
