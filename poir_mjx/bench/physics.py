"""``python -m poir_mjx.cli bench physics`` (run by ``make bench-env``): MJX physics presets side by side in one run.

Per task and preset (``poir_mjx/envs/physics.py``): milliseconds per physics substep at several batch sizes
(a control step of random actions timed and divided by its substeps, OSC torques included), and, where robosuite
is installed, the maximum end-effector and object error against robosuite on the grasp-and-lift replay the
fidelity test uses (``poir_mjx.envs.reference``, seed 1, replayed at batch 1 in the process's precision).
Writes ``<out>/<name>.json`` and ``.md`` after every row (an interrupted run keeps what it measured).
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.atomic import atomic_write_text
from poir_mjx.bench.env import device_name
from poir_mjx.compat import x64_enabled
from poir_mjx.envs.env import batched, float_dtype, make_env, make_params
from poir_mjx.envs.physics import physics_preset
from poir_mjx.optional import has_robosuite
from poir_mjx.bench.options import BenchPhysics
from poir_mjx.versions import command_line, stack, stack_line


class Stepper:
    """One preset's compiled batched step at one batch size, its state advanced by random actions."""

    def __init__(self, task: str, physics: str, batch: int):
        env = make_env(task, physics=physics)
        reset, _, self.step = batched(task, physics=physics)
        self.substeps = int(env.meta["substeps"])
        self.act = jax.random.uniform(jax.random.PRNGKey(1), (64, batch, env.action_size), minval=-1, maxval=1)
        self.k = 0
        t0 = time.perf_counter()
        params = make_params(np.full(batch, 0.02))
        self.state = jax.block_until_ready(reset(jax.random.split(jax.random.PRNGKey(0), batch), params))
        self.advance(1)
        self.compile_s = time.perf_counter() - t0

    def advance(self, steps: int) -> float:
        """Seconds per control step over `steps` steps."""
        t0 = time.perf_counter()
        for _ in range(steps):
            self.state = self.step(self.state, self.act[self.k % len(self.act)])
            self.k += 1
        jax.block_until_ready(self.state)
        return (time.perf_counter() - t0) / steps


def time_substep(task: str, presets, batch: int, steps: int, rounds: int) -> list[dict]:
    """ms per batched control step and per physics substep of each preset at one batch size (random actions in
    [-1, 1], sigma_init 0.02): the presets compiled, then timed in alternation, `rounds` rounds of `steps` steps
    each, so that other load on the machine falls on all of them alike; the fastest round counts."""
    steppers = {p: Stepper(task, p, batch) for p in presets}
    times = {p: [] for p in presets}
    for _ in range(rounds):
        for p, st in steppers.items():
            times[p].append(st.advance(steps))
    rows = []
    for p, st in steppers.items():
        dt, med = min(times[p]), float(np.median(times[p]))
        rows.append({"task": task, "physics": p, "batch": batch, "steps": steps, "rounds": rounds,
                     "ms_per_control_step": 1e3 * dt, "ms_per_substep": 1e3 * dt / st.substeps,
                     "median_ms_per_substep": 1e3 * med / st.substeps, "substeps": st.substeps,
                     "compile_and_first_step_s": st.compile_s, "load_average_1min": os.getloadavg()[0],
                     "diverged": int(np.asarray(st.state.info["diverged"]).sum())})  # fmt: skip
    return rows


def robosuite_replay(task: str):
    from poir_mjx.envs.reference import robosuite_grasp_rollout

    return robosuite_grasp_rollout(task, make_env(task).mj_model, seed=1)


def fidelity(task: str, physics: str, ref) -> dict:
    """The replay's actions stepped in MJX (batch 1) from robosuite's reset state: maximum errors over all steps."""
    env = make_env(task, physics=physics)
    _, reset_to, step = batched(task, physics=physics)
    params = make_params([0.0], [0.0])
    state = reset_to(jnp.asarray(ref.qpos0, float_dtype())[None], jax.random.split(jax.random.PRNGKey(4), 1), params)
    eef, obj, succ = [], [], []
    for a in ref.actions:
        state = step(state, jnp.asarray(a, float_dtype())[None])
        eef.append(np.asarray(state.obs["robot0_eef_pos"][0]))
        obj.append(np.asarray(state.data.xpos[0, env._idx["obj_body"]]))
        succ.append(bool(state.success[0]))
    eef, obj = np.array(eef), np.array(obj)
    return {"task": task, "physics": physics, "steps": len(ref.actions),
            "max_eef_error_mm": 1e3 * float(np.abs(eef - ref.eef_pos).max()),
            "max_object_error_mm": 1e3 * float(np.abs(obj - ref.obj_pos).max()),
            "object_lifted_mm": 1e3 * float(obj[-1, 2] - obj[0, 2]),
            "robosuite_object_lifted_mm": 1e3 * float(ref.obj_pos[-1, 2] - ref.obj_pos[0, 2]),
            "success_agrees_every_step": bool(np.array_equal(np.array(succ), np.asarray(ref.success))),
            "diverged": bool(np.asarray(state.info["diverged"])[0])}  # fmt: skip


def to_markdown(res: dict) -> str:
    presets = "; ".join(f"`{k}`: {v}" for k, v in res["presets"].items())
    lines = [
        "# MJX physics presets side by side",
        "",
        f"Device: {res['device']} ({res['machine']}); {res['stack_line']}; MJX in "
        f"{'float64' if res['x64'] else 'float32'}. Command: `{res['command']}`.",
        "",
        f"Presets (poir_mjx/envs/physics.py): {presets}.",
        "",
        "One control step = 25 physics substeps; ms per substep = ms per batched control step / 25 (random actions "
        f"in [-1, 1], sigma_init 0.02). The presets are timed in alternation at each batch size, {res['rounds']} "
        f"rounds of {res['steps']} control steps; the table gives the fastest round (the median in brackets) and "
        "the machine's 1-minute load average at the end of the timing.",
        "",
        "| task | physics | batch | ms per substep (median) | ms per control step | vs reference | compile + first step (s) "
        "| load |",
        "|---|---|---|---|---|---|---|---|",
    ]
    base = {(r["task"], r["batch"]): r["ms_per_substep"] for r in res["timing"] if r["physics"] == "reference"}
    for r in res["timing"]:
        ref = base.get((r["task"], r["batch"]))
        speed = f"{ref / r['ms_per_substep']:.2f}x" if ref else "-"
        lines.append(f"| {r['task']} | {r['physics']} | {r['batch']} | {r['ms_per_substep']:.2f} "
                     f"({r['median_ms_per_substep']:.2f}) | {r['ms_per_control_step']:.1f} | {speed} | "
                     f"{r['compile_and_first_step_s']:.0f} | {r['load_average_1min']:.1f} |")  # fmt: skip
    if res["fidelity"]:
        lines += [
            "",
            "Against robosuite on the fidelity test's grasp-and-lift replay (seed 1, all steps, batch 1):",
            "",
            "| task | physics | max end-effector error (mm) | max object error (mm) | object lifted, MJX / robosuite (mm) "
            "| success flag equal every step |",
            "|---|---|---|---|---|---|",
        ]
        for f in res["fidelity"]:
            lines.append(f"| {f['task']} | {f['physics']} | {f['max_eef_error_mm']:.2f} | {f['max_object_error_mm']:.2f} | "
                         f"{f['object_lifted_mm']:.0f} / {f['robosuite_object_lifted_mm']:.0f} | "
                         f"{'yes' if f['success_agrees_every_step'] else 'no'} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def run(opts: BenchPhysics) -> int:
    from poir_mjx.versions import machine_line

    res = {"device": device_name(), "machine": machine_line(), "command": command_line(), "versions": stack(),
           "stack_line": stack_line(), "x64": x64_enabled(), "steps": opts.steps, "rounds": opts.rounds,
           "presets": {p: str(physics_preset(p)) for p in opts.physics}, "timing": [], "fidelity": []}  # fmt: skip
    out = Path(opts.out)

    def write():
        atomic_write_text(out / f"{opts.name}.json", json.dumps(res, indent=2) + "\n")
        atomic_write_text(out / f"{opts.name}.md", to_markdown(res))

    fid = opts.fidelity and has_robosuite()
    for task in opts.tasks:
        sizes = opts.batch_sizes if task == "lift" else (opts.contact_rich_batch_sizes or opts.batch_sizes)
        ref = robosuite_replay(task) if fid else None
        for b in sizes:  # the presets side by side at each batch size
            res["timing"] += time_substep(task, opts.physics, b, opts.steps, opts.rounds)
            for r in res["timing"][-len(opts.physics):]:
                print(f"{task} {r['physics']} batch {b}: {r['ms_per_substep']:.2f} ms/substep", flush=True)
            write()
        for physics in opts.physics if fid else ():
            res["fidelity"].append(fidelity(task, physics, ref))
            f = res["fidelity"][-1]
            print(f"{task} {physics}: eef {f['max_eef_error_mm']:.2f} mm, object {f['max_object_error_mm']:.2f} mm",
                  flush=True)  # fmt: skip
            write()
    print(to_markdown(res))
    return 0
