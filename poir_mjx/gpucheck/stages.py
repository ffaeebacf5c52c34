"""The seven stages of a GPU check, in priority order; each adds rows to its Record as it measures them.

1. env: Lift MJX control steps/s per batch size, today's physics and the fast preset side by side (the reset
   compiled once per preset, at the largest batch).
2. e2e: EBC and POIR-DRIL evaluated episodes per minute on Lift (compiled ahead, timed apart), trained on the
   demos carried from a CPU (recorded in MJX where none were carried).
3. cell: one paper-size cell (PickPlaceCan at sigma_init 0.1, K 27, 5x300, N 4000, H 5): EBC, POIR-random and
   POIR-DRIL on the same episodes in MJX, trained on the device from the carried demos, one method at a time.
4. expert: the scripted expert's success in MJX (NutAssemblySquare with float64 physics).
5. sweep: a small Lift sweep (EBC, POIR-DRIL) whose batch is the e2e stage's, reusing its checkpoints.
6. planner: the POIR planner (DRIL, L2, MOREL) per batch: Hz per episode, FLOPs per call (XLA's cost
   analysis) and the achieved FLOP/s against the device's float32 peak where known.
7. warp: Lift's control step under MuJoCo Warp (physics "warp"), only where warp-lang was carried (docs/gpu.md).
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import jax
import numpy as np

from poir_mjx.gpucheck.record import Record
from poir_mjx.gpucheck.sizes import Sizes, overrides


@dataclasses.dataclass(frozen=True)
class Where:
    scratch: Path  # demos, checkpoints and run folders made on the device
    demos: Path  # demo files carried from a CPU, <task>.hdf5

    def demo_file(self, task: str) -> Path | None:
        f = self.demos / f"{task}.hdf5"
        return f if f.is_file() else None

    def demo_files(self, *tasks: str) -> dict[str, str]:
        return {t: str(self.demo_file(t)) for t in tasks if self.demo_file(t) is not None}

# Dense float32 (no tensor cores), vendor datasheets: the ceiling of full-precision matmuls.
PEAK_FP32 = {"H200": 67e12, "H100": 67e12, "A100": 19.5e12, "L40S": 91.6e12}


def peak_flops() -> float | None:
    kind = getattr(jax.devices()[0], "device_kind", "")
    return next((v for k, v in PEAK_FP32.items() if k in kind), None)


def env_stage(sizes: Sizes, rec: Record, where: Where) -> None:
    """Lift's batched control step under today's physics and the cheaper preset side by side, in one process."""
    for physics in sizes.env_physics:
        _time_lift(sizes, rec, physics)


def warp_stage(sizes: Sizes, rec: Record, where: Where) -> None:
    """Lift's batched control step under MuJoCo Warp (physics "warp"), last: only where warp-lang was carried in
    parts (make warp-parts here, make warp-install there: docs/gpu.md)."""
    from poir_mjx.optional import warp_installed

    if not warp_installed():
        rec.add({"task": "lift", "physics": "warp", "not_run": "warp-lang is not installed (make warp-install)"})
        return
    _time_lift(sizes, rec, "warp")


def _time_lift(sizes: Sizes, rec: Record, physics: str) -> None:
    from poir_mjx.envs.env import batched, make_env, make_params

    env = make_env("lift", physics=physics)
    reset, _, step = batched("lift", physics=physics)
    # One reset at the largest size, sliced, except under Warp: its contact buffers are sized by the batch
    sliced = not env.on_warp

    def start(b):
        t0 = time.perf_counter()
        state = jax.block_until_ready(reset(jax.random.split(jax.random.PRNGKey(0), b), make_params(np.full(b, 0.02))))
        return state, time.perf_counter() - t0

    big = max(sizes.env_batches)
    state, reset_s = start(big) if sliced else (None, 0.0)
    for b in sizes.env_batches:
        st, reset_s = (jax.tree_util.tree_map(lambda x: x[:b], state), reset_s) if sliced else start(b)
        act = jax.random.uniform(jax.random.PRNGKey(b), (sizes.env_steps + 1, b, env.action_size), minval=-1,
                                 maxval=1)  # fmt: skip
        t0 = time.perf_counter()
        st = jax.block_until_ready(step(st, act[0]))
        compile_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        for k in range(1, sizes.env_steps + 1):
            st = step(st, act[k])
        jax.block_until_ready(st)
        dt = time.perf_counter() - t0
        rec.add({"task": "lift", "physics": physics, "batch": b, "steps": sizes.env_steps,
                 "control_steps_per_s": b * sizes.env_steps / dt, "ms_per_batched_step": 1e3 * dt / sizes.env_steps,
                 "compile_and_first_step_s": compile_s,
                 f"reset_compile_and_run_s_at_batch_{big if sliced else b}": reset_s,
                 "diverged": int(np.asarray(st.info["diverged"]).sum())})  # fmt: skip


def _flops(compiled) -> float | None:
    cost = compiled.cost_analysis()
    cost = cost[0] if isinstance(cost, (list, tuple)) and cost else cost
    return float(cost["flops"]) if isinstance(cost, dict) and "flops" in cost else None


def planner_stage(sizes: Sizes, rec: Record, where: Where) -> None:
    from poir_mjx.bench.flops import planner_matmul_flops
    from poir_mjx.bench.planner import ACT, OBS, random_params
    from poir_mjx.core.agent import POIR
    from poir_mjx.core.config import PRESETS

    peak = peak_flops()
    for reward in ("dril", "l2", "morel"):
        base = PRESETS[sizes.planner_preset]
        agent = POIR(dataclasses.replace(base, planner=dataclasses.replace(base.planner, reward=reward)), OBS, ACT)
        params = random_params(agent, sizes.expert_states, jax.random.PRNGKey(0))
        plan = jax.jit(jax.vmap(agent.plan, in_axes=(None, 0, 0)))
        for b in sizes.planner_batches:
            obs = jax.random.normal(jax.random.PRNGKey(1), (b, OBS))
            keys = jax.random.split(jax.random.PRNGKey(2), b)
            t0 = time.perf_counter()
            compiled = plan.lower(params, obs, keys).compile()
            jax.block_until_ready(compiled(params, obs, keys))
            compile_s = time.perf_counter() - t0
            t0 = time.perf_counter()
            for c in range(sizes.planner_calls):
                out = compiled(params, obs, jax.random.split(jax.random.PRNGKey(3 + c), b))
            jax.block_until_ready(out)
            dt = (time.perf_counter() - t0) / sizes.planner_calls
            flops = planner_matmul_flops(agent, params, b)  # XLA's count misses the loops (bench/flops.py)
            pc = agent.config.planner
            rec.add({"preset": sizes.planner_preset, "reward": reward, "episodes": b, "N": pc.num_trajectories,
                     "H": pc.horizon, "K": agent.config.ensemble_size, "ms_per_call": 1e3 * dt, "hz_per_episode": 1 / dt,
                     "episode_steps_per_s": b / dt, "compile_and_first_s": compile_s, "matmul_flops_per_call": flops,
                     "xla_cost_analysis_flops": _flops(compiled), "achieved_flop_s": flops / dt, "peak_fp32_flop_s": peak,
                     "fraction_of_peak": flops / dt / peak if peak else None})  # fmt: skip


def e2e_stage(sizes: Sizes, rec: Record, where: Where) -> None:
    from poir_mjx.bench.e2e import bench

    for method in ("EBC", "POIR-DRIL"):
        rec.add(bench(sizes.e2e_preset, method, sizes.e2e_episodes, sizes.e2e_steps, sizes.num_demos,
                      demo_simulator="mjx", demo_batch=sizes.demo_batch, overrides=overrides(sizes),
                      data_dir=where.scratch / "data", ckpt_dir=where.scratch / "checkpoints",
                      demo_file=where.demo_file("lift")))  # fmt: skip


def cell_stage(sizes: Sizes, rec: Record, where: Where) -> None:
    """The paper-size cell, one method at a time (each its own run folder, the same episode keys: paired), a row
    as each method's cell is written, so a deadline keeps the finished methods."""
    from poir_mjx.sweep.artifacts import cell_path
    from poir_mjx.sweep.config import SweepConfig
    from poir_mjx.sweep.run import run_sweep

    task = sizes.cell_task
    for m in sizes.cell_methods:
        cfg = SweepConfig(name=f"gpu-check-cell-{m.lower()}", preset=sizes.cell_preset, tasks=(task,), methods=(m,),
                          sigma_init=(sizes.cell_sigma_init,), episodes=sizes.cell_episodes, max_steps=sizes.e2e_steps,
                          num_demos=sizes.num_demos, demo_simulator="mjx", demo_batch=sizes.demo_batch,
                          demo_files=where.demo_files(task), simulator="mjx", overrides=overrides(sizes))  # fmt: skip
        t0 = time.perf_counter()
        out = run_sweep(cfg, where.scratch / "results", where.scratch / "data", where.scratch / "checkpoints",
                        progress=False, replace_config=True)  # fmt: skip
        cell = json.loads(cell_path(out, task, m, sizes.cell_sigma_init, 0.0, 0).read_text())
        rec.add({"task": task, "preset": sizes.cell_preset, "method": m, "sigma_init": sizes.cell_sigma_init,
                 "successes": cell["successes"], "episodes": cell["episodes"], "wilson95": cell["wilson95"],
                 "demos": cell["data"].get("source"), "demo_sha256": cell["data"].get("sha256"),
                 "training_and_evaluation_s": time.perf_counter() - t0})  # fmt: skip


def sweep_config(sizes: Sizes):
    from poir_mjx.sweep.config import SweepConfig

    return SweepConfig(name="gpu-check-lift", preset=sizes.e2e_preset, tasks=("lift",), methods=("EBC", "POIR-DRIL"),
                       sigma_init=sizes.sweep_sigma_init, episodes=sizes.e2e_episodes // len(sizes.sweep_sigma_init),
                       max_steps=sizes.e2e_steps, num_demos=sizes.num_demos, demo_simulator="mjx",
                       demo_batch=sizes.demo_batch, simulator="mjx", overrides=overrides(sizes))  # fmt: skip


def sweep_stage(sizes: Sizes, rec: Record, where: Where) -> None:
    from poir_mjx.sweep.artifacts import cell_path
    from poir_mjx.sweep.run import run_sweep

    cfg = dataclasses.replace(sweep_config(sizes), demo_files=where.demo_files("lift"))
    t0 = time.perf_counter()
    out = run_sweep(cfg, where.scratch / "results", where.scratch / "data", where.scratch / "checkpoints", progress=False,
                    replace_config=True)  # fmt: skip
    wall = time.perf_counter() - t0
    for m in cfg.methods:
        for si in cfg.sigma_init:
            cell = json.loads(cell_path(out, "lift", m, si, 0.0, 0).read_text())
            rec.add({"method": m, "sigma_init": si, "successes": cell["successes"], "episodes": cell["episodes"],
                     "wilson95": cell["wilson95"], "simulator": cell.get("simulator"), "sweep_wall_s": wall})  # fmt: skip


def expert_stage(sizes: Sizes, rec: Record, where: Where) -> None:
    from poir_mjx.compat import enable_x64
    from poir_mjx.eval.expert_success import mjx_success

    for task in sizes.expert_tasks:
        x64 = task == "nut_assembly_square"  # its grasp needs float64 physics (docs/expert-data.md)
        with enable_x64(x64):
            r = mjx_success(task, sizes.expert_episodes, seed=1, sigma_init=0.02, steps=sizes.expert_steps or None)
        rec.add({"task": task, "sigma_init": 0.02, "x64": x64, **r})


STAGE_FUNCTIONS = {"env": env_stage, "e2e": e2e_stage, "cell": cell_stage, "expert": expert_stage,
                   "sweep": sweep_stage, "planner": planner_stage, "warp": warp_stage}  # fmt: skip
