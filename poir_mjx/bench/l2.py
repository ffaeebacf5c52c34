"""``make bench-l2`` (``python -m poir_mjx.cli bench l2``): the L2 reward's exact nearest-expert search, the full
scan against the shortlist (``PlannerConfig.l2_shortlist``, core/nearest.py), in one process on the same states.

The agent is a sweep run's POIR-L2 agent (its checkpoint, its expert states, its ranking's L2 dimensions); the states
are those its cells' episodes visit in robosuite (every few steps, as ``bench precision`` takes them) and demo
states. Per state group: one batched planner call over every state of the group (as a sweep batches its episodes),
timed under each search with the same keys; the planned actions of the two (identical when the search is exact); and,
for every imagined step of every call, how many expert states the shortlist measured and how often it had to scan.
"""

from __future__ import annotations

import json
import math
import time

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.atomic import atomic_write_text
from poir_mjx.bench.options import BenchL2
from poir_mjx.bench.precision import require_robosuite as _require, run_config, states, with_planner
from poir_mjx.core import nearest
from poir_mjx.core.agent import POIR
from poir_mjx.core.config import ConfigError
from poir_mjx.versions import command_line, machine_line, simulator_line, stack


def require_robosuite() -> None:
    _require()


def with_shortlist(agent: POIR, shortlist: int) -> POIR:
    return with_planner(agent, l2_shortlist=shortlist)


def timed(fn, calls: int) -> tuple[float, float, np.ndarray]:
    """(first call's seconds (compilation included), median seconds of `calls` more, the last result)."""
    t0 = time.perf_counter()
    out = jax.block_until_ready(fn())
    first = time.perf_counter() - t0
    times = []
    for _ in range(calls):
        t0 = time.perf_counter()
        out = jax.block_until_ready(fn())
        times.append(time.perf_counter() - t0)
    return first, float(np.median(times)), np.asarray(out)


def measured_fn(agent: POIR, shortlist: int):
    """jit((params, obs, key) -> (expert states each head's shortlist measured, queries scanned against every expert
    state), each [H], at every imagined step of one planner call, on the states the L2 reward scores)."""
    pc = agent.config.planner
    dims = jnp.asarray(pc.l2_dims) if pc.l2_dims else None

    def fn(params, obs, key):
        imag = agent.imagine(params, obs, key)
        scored = imag.states[1:] if agent.scores_next_state() else imag.states[:-1]  # [H, K, M, ds]
        expert = params.expert_states if dims is None else params.expert_states[:, dims]
        flat = scored.reshape(scored.shape[0], -1, scored.shape[-1])
        if dims is not None:
            flat = flat[..., dims]

        def one(q):
            stats = nearest.search(q, expert, shortlist, pc.l2_chunk, groups=scored.shape[1])[1]
            return stats["shortlist"], stats["scanned"]

        return jax.vmap(one)(flat)

    return jax.jit(jax.vmap(fn, in_axes=(None, 0, 0)))


def compare(opts: BenchL2, agent: POIR, params, groups) -> list[dict]:
    full, short = with_shortlist(agent, 0), with_shortlist(agent, opts.shortlist)
    plans = {n: jax.jit(jax.vmap(a.plan, in_axes=(None, 0, 0))) for n, a in (("scan", full), ("shortlist", short))}
    count = measured_fn(agent, opts.shortlist)
    e_count = int(params.expert_states.shape[0])
    queries = math.prod(agent.head_layout())  # imagined states per step of one call (padding cells included)
    rows = []
    for group, (obs, keys) in groups.items():
        obs, keys = jnp.asarray(obs, jnp.float32), jnp.asarray(keys, jnp.uint32)
        res = {n: timed(lambda f=f: f(params, obs, keys), opts.calls) for n, f in plans.items()}
        shortlisted, scanned = (np.asarray(x) for x in count(params, obs, keys))  # [S, H] each
        rows.append({"group": group, "states": int(obs.shape[0]), "expert_states": e_count,
                     "scan_s": res["scan"][1], "shortlist_s": res["shortlist"][1],
                     "scan_first_s": res["scan"][0], "shortlist_first_s": res["shortlist"][0],
                     "speedup": res["scan"][1] / res["shortlist"][1],
                     "action_max_diff": float(np.abs(res["scan"][2] - res["shortlist"][2]).max()),
                     "shortlist_measured_mean": float(shortlisted.mean()),
                     "scanned_share": float(scanned.mean() / queries),
                     "steps_none_scanned": float((scanned == 0).mean())})  # fmt: skip
        print(f"{group}: scan {res['scan'][1]:.3f} s, shortlist {res['shortlist'][1]:.3f} s per batched call",
              flush=True)  # fmt: skip
    return rows


def to_markdown(res: dict) -> str:
    lines = ["# The L2 reward's nearest-expert search: full scan against the shortlist", "",
             f"Run {res['run']}, task {res['task']}, {res['method']}, seed {res['seed']}; {res['machine']}; "
             f"{res['simulator']} for the states. Command: `{res['command']}`.", "",
             f"One batched planner call over every state of a group (as a sweep batches its episodes), the same keys "
             f"under both searches, median of {res['calls']} calls after a first (compiling) one. Shortlist "
             f"{res['shortlist']}: per head, the expert states nearest to the centre of that head's imagined states at "
             "a step, measured nearest first until the triangle inequality certifies each query's nearest; the "
             "queries it cannot certify are scanned against every expert state (core/nearest.py). 'shortlist "
             "measured': expert states a head's shortlist measured per imagined step (mean); 'queries scanned': "
             "the share of imagined states scanned against all of them; 'steps with none': the share of imagined "
             "steps (of one episode's call) needing no scan. The two searches give the same distances, so the same "
             "actions.", "",
             "| states | n | expert states | full scan s / call | shortlist s / call | speedup | shortlist measured "
             "| queries scanned | steps with none | max action difference |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in res["rows"]:
        lines.append(f"| {r['group']} | {r['states']} | {r['expert_states']} | {r['scan_s']:.3f} | "
                     f"{r['shortlist_s']:.3f} | {r['speedup']:.1f}x | {r['shortlist_measured_mean']:.0f} | "
                     f"{r['scanned_share']:.1%} | {r['steps_none_scanned']:.0%} | {r['action_max_diff']:.2g} |")
    return "\n".join(lines) + "\n"


def run(opts: BenchL2) -> int:
    from poir_mjx.sweep.artifacts import load_run_agent

    run_cfg = run_config(opts)
    agent, params, m = load_run_agent(opts.run, opts.task, opts.method, opts.seed, opts.data, opts.checkpoints)
    if m.act != "plan" or agent.config.planner.reward != "l2":
        raise ConfigError(f"--method: {opts.method} does not plan with the L2 reward")
    groups = states(opts, run_cfg, with_shortlist(agent, opts.shortlist), params)
    res = {"run": str(opts.run), "task": opts.task, "method": opts.method, "seed": opts.seed,
           "shortlist": opts.shortlist, "calls": opts.calls, "command": command_line(), "machine": machine_line(),
           "stack": stack(), "simulator": simulator_line("robosuite"), "rows": compare(opts, agent, params, groups)}
    atomic_write_text(opts.out / f"{opts.name}.json", json.dumps(res, indent=1) + "\n")
    atomic_write_text(opts.out / f"{opts.name}.md", to_markdown(res))
    print(to_markdown(res))
    return 0
