"""``make bench-e2e`` (``python -m poir_mjx.cli bench e2e``): end-to-end evaluation throughput, evaluated
episodes per minute, per method and preset.

Uses the sweep's own pieces (demos made on first use, trained checkpoints reused, the compiled
evaluator) on Lift; times one batch after a warm-up call that includes compilation.
Writes ``<out>/e2e.{json,md}``.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import jax
import numpy as np

from poir_mjx.atomic import atomic_write_text
from poir_mjx.bench.env import device_name
from poir_mjx.cli import command_line
from poir_mjx.cli.options import BenchE2E
from poir_mjx.envs.env import make_params
from poir_mjx.eval.artifacts import demos_for, train_or_load
from poir_mjx.eval.episodes import mjx_evaluator
from poir_mjx.eval.methods import get_method
from poir_mjx.rollout.sharding import run_batch
from poir_mjx.eval.sweep_config import SweepConfig


def bench(preset: str, method_name: str, episodes: int, steps: int, num_demos: int) -> dict:
    cfg = SweepConfig(name="bench", preset=preset, methods=(method_name,), episodes=episodes,
                         max_steps=steps, num_demos=num_demos)  # fmt: skip
    method = get_method(method_name)
    tr, prov = demos_for(cfg, "lift", Path("data/demos"))
    agent, params, _ = train_or_load(method, cfg, "lift", 0, tr, prov, Path("checkpoints"))
    evaluator = mjx_evaluator("lift", method, agent, steps)
    env_params = make_params(np.full(episodes, 0.2), 0.0)
    t0 = time.perf_counter()
    run_batch(evaluator, params, jax.random.split(jax.random.PRNGKey(0), episodes), env_params)
    first = time.perf_counter() - t0
    t0 = time.perf_counter()
    res = run_batch(evaluator, params, jax.random.split(jax.random.PRNGKey(1), episodes), env_params)
    dt = time.perf_counter() - t0
    return {"preset": preset, "method": method_name, "episodes": episodes, "steps": steps, "seconds": dt,
            "compile_and_first_s": first, "episodes_per_min": 60 * episodes / dt,
            "episode_steps_per_s": episodes * steps / dt, "successes": int((res["first_success"] >= 0).sum())}  # fmt: skip


def run(opts: BenchE2E) -> int:
    for m in opts.methods:
        get_method(m)  # an unknown method: one line before any work
    rows = [bench(pr, m, opts.episodes, opts.steps, opts.num_demos) for pr in opts.presets for m in opts.methods]
    res = {"device": device_name(), "jax": jax.__version__, "x64": bool(jax.config.jax_enable_x64),
           "command": command_line(), "rows": rows}  # fmt: skip
    lines = ["# End-to-end evaluation throughput (Lift, sigma_init 0.2)", "",
             f"Device: {res['device']}; jax {res['jax']}, x64 {res['x64']}. Command: `{res['command']}`. "
             "One batch of episodes, timed after a warm-up batch that includes compilation.", "",
             "| preset | method | episodes x steps | episodes/min | episode-steps/s | compile + first batch (s) |",
             "|---|---|---|---|---|---|"]  # fmt: skip
    for r in rows:
        lines.append(f"| {r['preset']} | {r['method']} | {r['episodes']} x {r['steps']} | {r['episodes_per_min']:.1f} | "
                     f"{r['episode_steps_per_s']:.1f} | {r['compile_and_first_s']:.0f} |")  # fmt: skip
    md = "\n".join(lines) + "\n"
    atomic_write_text(Path(opts.out) / "e2e.json", json.dumps(res, indent=2) + "\n")
    atomic_write_text(Path(opts.out) / "e2e.md", md)
    print(md)
    return 0

