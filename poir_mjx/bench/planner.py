"""``make bench-planner`` (``python -m poir_mjx.cli bench planner``): planner calls per second, one episode
and a batch, per preset and reward.

Network weights are random (speed does not depend on training); observation size 19 and action
size 7 are Lift's robomimic low-dim layout; the L2 reward searches ``--expert-states`` states
(default 30,000: 200 demonstrations of ~150 steps). Writes ``<out>/planner.{json,md}``.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import jax
import jax.numpy as jnp

from poir_mjx.atomic import atomic_write_text
from poir_mjx.bench.env import device_name
from poir_mjx.versions import command_line
from poir_mjx.bench.options import BenchPlanner
from poir_mjx.core import ensemble as ens
from poir_mjx.core.agent import POIR, POIRParams
from poir_mjx.core.config import PRESETS
from poir_mjx.core.normalizer import Normalizer

OBS, ACT = 19, 7


def random_params(agent: POIR, expert_states: int, key) -> POIRParams:
    k1, k2, k3 = jax.random.split(key, 3)
    k = agent.config.ensemble_size
    bc = ens.init_ensemble(agent.bc_module, k1, k, OBS)
    wm = ens.init_ensemble(agent.wm_module, k2, k, OBS + ACT)
    return POIRParams(
        bc=bc,
        wm=wm,
        reward_wm=wm,
        obs_norm=Normalizer(jnp.zeros(OBS), jnp.ones(OBS)),
        act_norm=Normalizer(jnp.zeros(ACT), jnp.ones(ACT)),
        expert_states=jax.random.normal(k3, (expert_states, OBS)),
        dril_level=jnp.zeros(()),
        morel_level=jnp.zeros(()),
    )


def bench_one(preset: str, reward: str, batch: int, calls: int, expert_states: int) -> dict:
    import dataclasses

    cfg = PRESETS[preset]
    cfg = dataclasses.replace(cfg, planner=dataclasses.replace(cfg.planner, reward=reward))
    agent = POIR(cfg, OBS, ACT)
    params = random_params(agent, expert_states, jax.random.PRNGKey(0))
    plan = jax.jit(jax.vmap(agent.plan, in_axes=(None, 0, 0)))
    obs = jax.random.normal(jax.random.PRNGKey(1), (batch, OBS))
    t0 = time.perf_counter()
    jax.block_until_ready(plan(params, obs, jax.random.split(jax.random.PRNGKey(2), batch)))
    compile_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    for c in range(calls):
        out = plan(params, obs, jax.random.split(jax.random.PRNGKey(3 + c), batch))
    jax.block_until_ready(out)
    dt = (time.perf_counter() - t0) / calls
    return {
        "preset": preset,
        "reward": reward,
        "batch": batch,
        "calls": calls,
        "compile_s": compile_s,
        "ms_per_call": 1e3 * dt,
        "calls_per_s": 1.0 / dt,
        "episode_steps_per_s": batch / dt,
        "N": cfg.planner.num_trajectories,
        "H": cfg.planner.horizon,
        "K": cfg.ensemble_size,
    }


def to_markdown(res: dict) -> str:
    lines = [
        "# Planner throughput",
        "",
        f"Device: {res['device']}; jax {res['jax']}. Command: `{res['command']}`. Random weights, obs 19 / action 7 "
        f"(Lift), L2 over {res['expert_states']} expert states. One call = one action for every episode in the batch.",
        "",
        "| preset | N | H | K | reward | episodes | ms per call | planner calls/s (Hz per episode) | episode-steps/s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in res["rows"]:
        lines.append(
            f"| {r['preset']} | {r['N']} | {r['H']} | {r['K']} | {r['reward']} | {r['batch']} | {r['ms_per_call']:.1f} | "
            f"{r['calls_per_s']:.2f} | {r['episode_steps_per_s']:.1f} |"
        )
    return "\n".join(lines) + "\n"


def run(opts: BenchPlanner) -> int:
    res = {
        "device": device_name(),
        "jax": jax.__version__,
        "command": command_line(),
        "expert_states": opts.expert_states,
        "rows": [],
    }
    out = Path(opts.out)
    for preset in opts.presets:
        batches = opts.paper_batch_sizes if (preset == "paper" and opts.paper_batch_sizes) else opts.batch_sizes
        for reward in opts.rewards:
            for b in batches:
                r = bench_one(preset, reward, b, opts.calls, opts.expert_states)
                res["rows"].append(r)
                print(f"{preset} {reward} batch {b}: {r['ms_per_call']:.1f} ms per call", flush=True)
                atomic_write_text(out / "planner.json", json.dumps(res, indent=2) + "\n")  # every row as it finishes
                atomic_write_text(out / "planner.md", to_markdown(res))
    print(to_markdown(res))
    return 0
