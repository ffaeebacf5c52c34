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
from poir_mjx.versions import command_line
from poir_mjx.bench.options import BenchE2E
from poir_mjx.envs.env import make_params
from poir_mjx.sweep.artifacts import demos_for, train_or_load
from poir_mjx.eval.episodes import mjx_evaluator
from poir_mjx.eval.methods import get_method
from poir_mjx.rollout.sharding import shard_inputs
from poir_mjx.sweep.config import SweepConfig


def default_demo_simulator() -> str:
    """robosuite where it is installed (the CPU set), else the scripted expert in MJX (the GPU machine)."""
    from poir_mjx.optional import has_robosuite

    return "robosuite" if has_robosuite() else "mjx"


def default_demo_batch() -> int:
    """MJX demo episodes per compiled batch: 256 on an accelerator, 16 on a CPU."""
    return 16 if jax.default_backend() == "cpu" else 256


def bench(preset: str, method_name: str, episodes: int, steps: int, num_demos: int, *, demo_simulator: str = "auto",
          demo_batch: int = 0, overrides: dict | None = None, data_dir: Path = Path("data/demos"),
          ckpt_dir: Path = Path("checkpoints"), demo_file: Path | None = None, task: str = "lift",
          sigma_init: float = 0.2) -> dict:  # fmt: skip
    """One batch of `episodes` evaluated episodes of `method_name` in MJX: compiled ahead of time (timed apart), then
    run once and timed. demo_file: a robomimic file to train on (e.g. demos recorded on a CPU and carried to a GPU);
    None: the scripted expert's demos, made on first use in `demo_simulator`."""
    cfg = SweepConfig(name="bench", preset=preset, tasks=(task,), methods=(method_name,), episodes=episodes,
                      max_steps=steps, num_demos=num_demos,
                      demo_simulator=default_demo_simulator() if demo_simulator == "auto" else demo_simulator,
                      demo_batch=demo_batch or default_demo_batch(), overrides=dict(overrides or {}),
                      demo_files={task: str(demo_file)} if demo_file is not None else {})  # fmt: skip
    method = get_method(method_name)
    t0 = time.perf_counter()
    tr, prov = demos_for(cfg, task, Path(data_dir))
    agent, params, _ = train_or_load(method, cfg, task, 0, tr, prov, Path(ckpt_dir))
    prepare = time.perf_counter() - t0
    evaluator = mjx_evaluator(task, method, agent, steps)
    inputs = shard_inputs(params, jax.random.split(jax.random.PRNGKey(1), episodes),
                          make_params(np.full(episodes, sigma_init), 0.0))  # fmt: skip
    t0 = time.perf_counter()
    compiled = evaluator.lower(*inputs).compile()
    first = time.perf_counter() - t0
    t0 = time.perf_counter()
    res = jax.tree_util.tree_map(np.asarray, compiled(*inputs))
    dt = time.perf_counter() - t0
    return {"task": task, "preset": preset, "method": method_name, "episodes": episodes, "steps": steps,
            "sigma_init": sigma_init, "seconds": dt, "compile_s": first, "demos_and_training_s": prepare,
            "demos": prov.get("source"), "demo_sha256": prov.get("sha256"),
            "demo_simulator": prov.get("simulator", cfg.demo_simulator), "episodes_per_min": 60 * episodes / dt,
            "episode_steps_per_s": episodes * steps / dt,
            "successes": int((res["first_success"][:episodes] >= 0).sum())}  # fmt: skip


def to_markdown(res: dict) -> str:
    lines = ["# End-to-end evaluation throughput (Lift, sigma_init 0.2)", "",
             f"Device: {res['device']}; jax {res['jax']}, x64 {res['x64']}. Command: `{res['command']}`. "
             "One batch of episodes, compiled ahead of time and then run once (the compilation timed apart); demos "
             "(recorded in the simulator named) and training are timed apart.", "",
             "| preset | method | episodes x steps | episodes/min | episode-steps/s | compile (s) | "
             "demos + training (s) |", "|---|---|---|---|---|---|---|"]  # fmt: skip
    for r in res["rows"]:
        lines.append(f"| {r['preset']} | {r['method']} | {r['episodes']} x {r['steps']} | {r['episodes_per_min']:.1f} | "
                     f"{r['episode_steps_per_s']:.1f} | {r['compile_s']:.0f} | "
                     f"{r['demos_and_training_s']:.0f} ({r['demo_simulator']} demos) |")  # fmt: skip
    return "\n".join(lines) + "\n"


def run(opts: BenchE2E) -> int:
    for m in opts.methods:
        get_method(m)  # an unknown method: one line before any work
    res = {"device": device_name(), "jax": jax.__version__, "x64": bool(jax.config.jax_enable_x64),
           "command": command_line(), "rows": []}  # fmt: skip
    out = Path(opts.out)
    for pr in opts.presets:
        for m in opts.methods:
            res["rows"].append(bench(pr, m, opts.episodes, opts.steps, opts.num_demos,
                                     demo_simulator=opts.demo_simulator, demo_batch=opts.demo_batch))  # fmt: skip
            atomic_write_text(out / "e2e.json", json.dumps(res, indent=2) + "\n")  # every row as it finishes
            atomic_write_text(out / "e2e.md", to_markdown(res))
    print(to_markdown(res))
    return 0
