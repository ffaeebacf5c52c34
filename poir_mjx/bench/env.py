"""``make bench-env`` (``python -m poir_mjx.cli bench env``): control steps per second, MJX at several batch
sizes vs robosuite's env.step.

Writes ``<out>/<name>.json`` and ``<out>/<name>.md`` (``make bench-env``: name ``env-<STACK>``). Without
robosuite installed (the current dependency set) its row is left out. Also times ``mjx.kinematics`` on Lift at batch 1:
a regression guard for the jax/XLA CPU slowdown seen with newer jax (seconds instead of ms).
"""

from __future__ import annotations

import json
import platform
import time
from pathlib import Path

import jax
import numpy as np

from poir_mjx.atomic import atomic_write_text
from poir_mjx.versions import command_line
from poir_mjx.bench.options import BenchEnv
from poir_mjx.envs.env import batched, make_env, make_params
from poir_mjx.envs.tasks import make_robosuite
from poir_mjx.optional import has_robosuite
from poir_mjx.versions import stack, stack_line


def device_name() -> str:
    d = jax.devices()[0]
    return f"{d.platform}:{getattr(d, 'device_kind', '')} x{jax.device_count()} ({platform.processor() or platform.machine()})"


def bench_robosuite(task: str, steps: int) -> dict:
    env = make_robosuite(task, seed=0)
    env.reset()
    rng = np.random.default_rng(0)
    for _ in range(5):  # numba warm-up
        env.step(rng.uniform(-1, 1, 7))
    t0 = time.perf_counter()
    for _ in range(steps):
        env.step(rng.uniform(-1, 1, 7))
    dt = time.perf_counter() - t0
    env.close()
    return {"steps": steps, "seconds": dt, "steps_per_s": steps / dt}


def bench_mjx(task: str, batch: int, steps: int) -> dict:
    env = make_env(task)
    reset, _, step = batched(task)
    params = make_params(np.full(batch, 0.02))
    t0 = time.perf_counter()
    state = reset(jax.random.split(jax.random.PRNGKey(0), batch), params)
    jax.block_until_ready(state)
    act = jax.random.uniform(jax.random.PRNGKey(1), (steps, batch, env.action_size), minval=-1, maxval=1)
    state = step(state, act[0])
    jax.block_until_ready(state)
    compile_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    for k in range(steps):
        state = step(state, act[k])
    jax.block_until_ready(state)
    dt = time.perf_counter() - t0
    return {
        "batch": batch,
        "steps": steps,
        "seconds": dt,
        "compile_and_first_step_s": compile_s,
        "control_steps_per_s": batch * steps / dt,
        "ms_per_batched_step": 1e3 * dt / steps,
        "diverged": int(np.asarray(state.info["diverged"]).sum()),
    }


def bench_kinematics() -> dict:
    from mujoco import mjx

    env = make_env("lift")
    d = mjx.make_data(env.model)
    f = jax.jit(lambda d: mjx.kinematics(env.model, d))
    jax.block_until_ready(f(d))
    t0 = time.perf_counter()
    for _ in range(20):
        out = f(d)
    jax.block_until_ready(out)
    return {"lift_kinematics_ms": 1e3 * (time.perf_counter() - t0) / 20}


def to_markdown(res: dict) -> str:
    lines = [
        "# Environment throughput (control steps per second)",
        "",
        f"Device: {res['device']}; {res['stack_line']}. Command: `{res['command']}`. "
        "One control step = 25 physics substeps (50 ms simulated). MJX: random actions in [-1, 1], "
        "sigma_init 0.02; robosuite: `env.step` in one process.",
        "",
        f"MJX kinematics regression guard (Lift, batch 1): {res['kinematics']['lift_kinematics_ms']:.2f} ms per call.",
        "",
        "| task | simulator | batch | control steps/s | ms per batched step | compile + first step (s) |",
        "|---|---|---|---|---|---|",
    ]
    for task, r in res["tasks"].items():
        rs = r["robosuite"]
        if rs is not None:
            lines.append(f"| {task} | robosuite (MuJoCo C) | 1 | {rs['steps_per_s']:.1f} | {1e3 / rs['steps_per_s']:.1f} | - |")
        for m in r["mjx"]:
            lines.append(
                f"| {task} | MJX | {m['batch']} | {m['control_steps_per_s']:.1f} | "
                f"{m['ms_per_batched_step']:.1f} | {m['compile_and_first_step_s']:.0f} |"
            )
    return "\n".join(lines) + "\n"


def run(opts: BenchEnv) -> int:
    res = {
        "device": device_name(),
        "command": command_line(),
        "versions": stack(),
        "stack_line": stack_line(),
        "kinematics": bench_kinematics(),
        "tasks": {},
    }
    out = Path(opts.out)

    def write():  # after every row: an interrupted run keeps what it measured
        atomic_write_text(out / f"{opts.name}.json", json.dumps(res, indent=2) + "\n")
        atomic_write_text(out / f"{opts.name}.md", to_markdown(res))

    for task in opts.tasks:
        r = res["tasks"][task] = {"robosuite": bench_robosuite(task, opts.robosuite_steps) if has_robosuite() else None,
                                  "mjx": []}  # fmt: skip
        write()
        rich = task != "lift" and opts.contact_rich_batch_sizes
        sizes = opts.contact_rich_batch_sizes if rich else opts.batch_sizes
        for b in sizes:
            r["mjx"].append(bench_mjx(task, b, opts.steps))
            print(f"{task} batch {b}: {r['mjx'][-1]['control_steps_per_s']:.1f} steps/s", flush=True)
            write()
    print(to_markdown(res))
    return 0
