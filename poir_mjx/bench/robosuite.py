"""``make bench-robosuite`` (``python -m poir_mjx.cli bench robosuite``): episodes in robosuite, bare stepping
next to EBC and POIR-DRIL collection (plain and overlapped), on the same workers in the same run.

Bare: the workers step zero actions (no policy, no main-process work). Each method: ``robosuite_eval.collect``
(the online deployments' loop, transitions recorded) after a two-step warm-up call that compiles the
planner for the same batch shape. Rates count the environment steps taken (an episode stops at
success) over the whole call, resets included, so bare and collection are timed alike. Writes
``<out>/robosuite-e2e.{json,md}`` after every row, so an interrupted run keeps what it measured.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import jax
import numpy as np

from poir_mjx.atomic import atomic_write_text
from poir_mjx.bench.env import device_name
from poir_mjx.versions import command_line
from poir_mjx.bench.options import BenchRobosuite
from poir_mjx.eval import robosuite_eval
from poir_mjx.rollout.evaluator import episode_keys
from poir_mjx.versions import stack_line


def bare(task: str, episodes: int, steps: int, workers: int) -> dict:
    per = -(-episodes // workers)
    seeds, _ = robosuite_eval.episode_streams(episode_keys(0, episodes), steps)
    t0 = time.perf_counter()
    with robosuite_eval.RobosuitePool(task, workers, per) as pool:
        pool.reset([(int(s), 0.3, 0.0) for s in seeds])
        zeros = np.zeros((pool.size, 7))
        for _ in range(steps):
            pool.step(zeros)
    return _row("bare stepping (zero actions)", "-", episodes, episodes * steps, time.perf_counter() - t0, workers)


def method_rows(opts: BenchRobosuite, method_name: str, workers: int) -> list[dict]:
    from poir_mjx.sweep.artifacts import demos_for, train_or_load
    from poir_mjx.eval.methods import get_method
    from poir_mjx.sweep.config import SweepConfig

    cfg = SweepConfig(name="bench", methods=(method_name,), simulator="robosuite", workers=workers)
    method = get_method(method_name)
    tr, prov = demos_for(cfg, opts.task, Path("data/demos"))
    agent, params, _ = train_or_load(method, cfg, opts.task, 0, tr, prov, Path("checkpoints"))
    policy = method.policy_fn(agent)
    keys, n = episode_keys(1, opts.episodes), opts.episodes
    si = np.full(n, opts.sigma_init)
    rows = []
    for overlap in (False, True):
        robosuite_eval.collect(opts.task, policy, params, keys, si, 0.0, 2, workers, overlap=overlap)  # compiles
        t0 = time.perf_counter()
        out, (_, _, _, valid) = robosuite_eval.collect(opts.task, policy, params, keys, si, 0.0, opts.steps, workers,
                                                       overlap=overlap)  # fmt: skip
        taken = int(valid.sum() + out["diverged"].sum())
        rows.append(_row(f"{method_name} collection", "two groups" if overlap else "none", n, taken,
                         time.perf_counter() - t0, workers, int((out["first_success"] >= 0).sum())))  # fmt: skip
    return rows


def _row(what, overlap, episodes, env_steps, seconds, workers, successes=None) -> dict:
    return {"what": what, "overlap": overlap, "episodes": episodes, "env_steps": env_steps, "seconds": seconds,
            "workers": workers, "env_steps_per_s": env_steps / seconds, "episodes_per_min": 60 * episodes / seconds,
            "successes": successes}  # fmt: skip


def _write(out: Path, res: dict) -> str:
    bare_rate = next((r["env_steps_per_s"] for r in res["rows"] if r["what"].startswith("bare")), None)
    lines = [f"# robosuite episodes: bare stepping vs collection ({res['task']}, sigma_init {res['sigma_init']})", "",
             f"Machine: {res['device']}, {res['cores']} cores; {res['stack']}. Command: `{res['command']}`. "
             f"{res['workers']} worker processes; {res['episodes']} episodes of at most {res['steps']} steps per row; "
             "whole calls timed (resets included; episodes stop at success; the planner compiled beforehand).", "",
             "| what | overlap | env steps | seconds | env-steps/s | episodes/min | bare / this |",
             "|---|---|---|---|---|---|---|"]  # fmt: skip
    for r in res["rows"]:
        ratio = f"{bare_rate / r['env_steps_per_s']:.2f}" if bare_rate else "-"
        lines.append(f"| {r['what']} | {r['overlap']} | {r['env_steps']} | {r['seconds']:.1f} | "
                     f"{r['env_steps_per_s']:.1f} | {r['episodes_per_min']:.1f} | {ratio} |")  # fmt: skip
    md = "\n".join(lines) + "\n"
    atomic_write_text(out / "robosuite-e2e.json", json.dumps(res, indent=2) + "\n")
    atomic_write_text(out / "robosuite-e2e.md", md)
    return md


def run(opts: BenchRobosuite) -> int:
    from poir_mjx.eval.methods import get_method
    from poir_mjx.optional import require_robosuite

    require_robosuite("bench robosuite")
    for m in opts.methods:
        get_method(m)  # an unknown method: one line before any work
    workers = opts.workers or os.cpu_count() or 1
    res = {"device": device_name(), "cores": os.cpu_count(), "stack": stack_line(), "jax": jax.__version__,
           "command": command_line(), "task": opts.task, "sigma_init": opts.sigma_init, "workers": workers,
           "episodes": opts.episodes, "steps": opts.steps, "rows": []}  # fmt: skip
    res["rows"].append(bare(opts.task, opts.episodes, opts.steps, workers))
    md = _write(Path(opts.out), res)
    for m in opts.methods:
        for row in method_rows(opts, m, workers):
            res["rows"].append(row)
            md = _write(Path(opts.out), res)
    print(md)
    return 0
