"""``python -m poir_mjx.cli bench precision``: does a reduced matmul precision change what the planner decides?

For a sweep run's agents, the planner is called at the same states with the same keys under true float32 and under
each reduced setting (``PlannerConfig.matmul``: TF32 or bfloat16 inputs, float32 accumulation, emulated exactly on a
CPU). The states are those the run's cells' episodes visit in robosuite (driven by the float32 planner, every few
steps) and demo states. Per setting: how often the top-k set is the same, how many of its k trajectories are shared,
how far the planned action moves (environment units) and how often its gripper sign flips; EBC's action likewise.
"""

from __future__ import annotations

import dataclasses
import json
import sys

import jax
import numpy as np

from poir_mjx.atomic import atomic_write_text
from poir_mjx.bench.options import BenchPrecision
from poir_mjx.core.agent import POIR
from poir_mjx.core.config import ConfigError
from poir_mjx.versions import command_line, machine_line, simulator_line, stack


def require_robosuite() -> None:
    """The command line's check before any work: the states come from robosuite episodes."""
    from poir_mjx.optional import require_robosuite as require

    require("bench precision (the states come from robosuite episodes)")


def with_planner(agent: POIR, **fields) -> POIR:
    """The agent with these planner fields replaced (everything else the same)."""
    return POIR(dataclasses.replace(agent.config, planner=dataclasses.replace(agent.config.planner, **fields)),
                agent.obs_size, agent.act_size)  # fmt: skip


def with_matmul(agent: POIR, matmul: str) -> POIR:
    return with_planner(agent, matmul=matmul)


def decide_fn(agent: POIR):
    """jit((params, obs, key) -> {plan, ebc: env actions; top: the top-k trajectory indices (by return)})."""
    k, m = agent.head_layout()
    pc = agent.config.planner
    real = (np.arange(k)[:, None] + k * np.arange(m)[None, :] < pc.num_trajectories).reshape(-1)

    def fn(params, obs, key):
        imag = agent.imagine(params, obs, key)
        ret = jax.numpy.where(real, imag.returns.reshape(-1), -jax.numpy.inf)
        return {"plan": agent._to_env_action(params, agent.select(imag.returns, imag.actions[0], key)),
                "ebc": agent.ebc_action(params, obs), "top": jax.lax.top_k(ret, pc.top_k)[1]}  # fmt: skip

    return jax.jit(fn)


def states(opts: BenchPrecision, run_cfg, agent: POIR, params) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{group: (obs [S, ds], keys [S, 2])}: every `every` steps of the cells' first episodes, and demo states."""
    from poir_mjx.diagnose.probe import plan_fn
    from poir_mjx.diagnose.run import cell_index, noise_grid
    from poir_mjx.diagnose.simulate import run_episode
    from poir_mjx.eval.robosuite_eval import episode_streams
    from poir_mjx.rollout.evaluator import episode_keys

    grid, n_ep = noise_grid(run_cfg), run_cfg.episodes
    if opts.episodes > n_ep:
        raise ConfigError(f"--episodes: {opts.episodes} is more than the run's {n_ep} episodes per cell")
    all_keys = episode_keys(opts.seed, len(grid) * n_ep)
    policy = plan_fn(agent)
    out = {}
    for si in opts.sigma_init:
        j = cell_index(run_cfg, opts.run / "config.json", si)
        seeds, step_keys = episode_streams(all_keys[j * n_ep : j * n_ep + opts.episodes], opts.steps)
        obs, keys = [], []
        for e in range(opts.episodes):
            _, snaps = run_episode(opts.task, int(seeds[e]), si, lambda o, k: np.asarray(policy(params, o, k)),
                                   np.asarray(step_keys[e]), opts.steps, opts.every, e)  # fmt: skip
            obs += [s.obs for s in snaps]
            keys += [s.key for s in snaps]
        out[f"episodes, sigma_init {si:g}"] = (np.stack(obs), np.stack(keys))
        print(f"sigma_init {si:g}: {len(obs)} states", file=sys.stderr, flush=True)
    if opts.demo_states:
        expert = np.asarray(params.obs_norm.inverse(params.expert_states[: opts.demo_states]))
        keys = np.asarray(jax.vmap(lambda i: jax.random.fold_in(jax.random.PRNGKey(opts.seed), i))(
            np.arange(len(expert))))  # fmt: skip
        out["demo states"] = (expert, keys)
    return out


def compare(agent: POIR, params, matmuls, groups) -> list[dict]:
    """One row per (state group, matmul): its decisions against float32's at the same states and keys."""
    ref_fn = decide_fn(with_matmul(agent, "float32"))
    fns = {m: decide_fn(with_matmul(agent, m)) for m in matmuls}
    k = agent.config.planner.top_k
    rows = []
    for group, (obs, keys) in groups.items():
        ref = [jax.tree_util.tree_map(np.asarray, ref_fn(params, o, kk)) for o, kk in zip(obs, keys)]
        for m, fn in fns.items():
            got = [jax.tree_util.tree_map(np.asarray, fn(params, o, kk)) for o, kk in zip(obs, keys)]
            shared = np.array([len(set(a["top"]) & set(b["top"])) for a, b in zip(ref, got)])
            d_plan = np.array([np.abs(a["plan"] - b["plan"]).max() for a, b in zip(ref, got)])
            d_ebc = np.array([np.abs(a["ebc"] - b["ebc"]).max() for a, b in zip(ref, got)])
            flips = np.array([np.sign(a["plan"][-1]) != np.sign(b["plan"][-1]) for a, b in zip(ref, got)])
            rows.append({"group": group, "matmul": m, "states": len(obs), "top_k": k,
                         "top_k_same": float((shared == k).mean()), "top_k_shared_mean": float(shared.mean() / k),
                         "plan_diff_median": float(np.median(d_plan)), "plan_diff_max": float(d_plan.max()),
                         "gripper_flips": float(flips.mean()), "ebc_diff_max": float(d_ebc.max())})  # fmt: skip
    return rows


def to_markdown(res: dict) -> str:
    lines = ["# The planner's decisions under reduced matmul precision", "",
             f"Run {res['run']}, task {res['task']}, seed {res['seed']}; {res['machine']}; {res['simulator']} for the "
             f"states. Agents trained on {_demos(res['demos'])}. Command: `{res['command']}`.", "",
             "Each reduced setting against true float32 at the same states with the same planner keys (candidates, "
             "noise and heads identical; only the networks' matmuls differ: inputs rounded to TF32 or bfloat16, "
             "float32 accumulation, emulated exactly on this CPU). Actions in robosuite's units (position and "
             "rotation commands in [-1, 1]); the gripper flips when the planned command's sign differs.", "",
             "| method | states | matmul | n | top-k set identical | top-k shared | planned action: median / max "
             "change | gripper sign flips | EBC action: max change |", "|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for method, rows in res["methods"].items():
        for r in rows:
            lines.append(f"| {method} | {r['group']} | {r['matmul']} | {r['states']} | {r['top_k_same']:.0%} | "
                         f"{r['top_k_shared_mean']:.0%} | {r['plan_diff_median']:.2g} / {r['plan_diff_max']:.2g} | "
                         f"{r['gripper_flips']:.0%} | {r['ebc_diff_max']:.2g} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def _demos(d: dict) -> str:
    what = d.get("path") if d.get("source") == "file" else f"{d.get('num_demos', '?')} scripted-expert demos"
    return f"{what} ({d.get('simulator', 'file')}, sha256 {d.get('sha256', '?')})"


def run_config(opts):
    """The sweep run folder's recorded config (opts.run), checked against --task: what a bench on a run's agent reads."""
    from poir_mjx.sweep.config import load_sweep_config

    src = opts.run / "config.json"
    if not src.is_file():
        raise ConfigError(f"{src}: no such file; expected a sweep run folder (results/<name>/)")
    run_cfg = load_sweep_config(src, recorded=True)
    if opts.task not in run_cfg.tasks:
        raise ConfigError(f"--task: {opts.task!r} is not a task of {src} (field 'tasks' {list(run_cfg.tasks)})")
    return run_cfg


def run(opts: BenchPrecision) -> int:
    from poir_mjx.sweep.artifacts import demos_for, load_run_agent

    run_cfg = run_config(opts)
    res = {"run": str(opts.run), "task": opts.task, "seed": opts.seed, "command": command_line(),
           "machine": machine_line(), "stack": stack(), "simulator": simulator_line("robosuite"),
           "demos": demos_for(run_cfg, opts.task, opts.data, progress=False)[1], "methods": {}}  # fmt: skip
    groups = None
    for method in opts.methods:
        agent, params, m = load_run_agent(opts.run, opts.task, method, opts.seed, opts.data, opts.checkpoints)
        if m.act != "plan":
            raise ConfigError(f"--methods: {method} does not plan")
        if groups is None:  # the first method's float32 planner drives the episodes; every method sees those states
            groups = states(opts, run_cfg, with_matmul(agent, "float32"), params)
        res["methods"][method] = compare(agent, params, opts.matmul, groups)
        atomic_write_text(opts.out / f"{opts.name}.json", json.dumps(res, indent=1) + "\n")
        atomic_write_text(opts.out / f"{opts.name}.md", to_markdown(res))
        print(to_markdown(res))
    return 0
