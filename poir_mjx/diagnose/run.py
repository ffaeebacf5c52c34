"""``diagnose``: a cell's episodes re-run in robosuite with its keys, the planner taken apart every few steps, one
record per episode (written atomically; a rerun reuses the finished ones), then the page."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import jax
import numpy as np

from poir_mjx.atomic import atomic_write_text
from poir_mjx.core.config import ConfigError
from poir_mjx.diagnose.config import SOURCE, DiagnoseConfig, check, default_out
from poir_mjx.versions import command_line, machine_line, simulator_line, stack


def run(cfg: DiagnoseConfig) -> int:
    check(cfg)
    from poir_mjx.diagnose.report import write_page
    from poir_mjx.sweep.artifacts import load_run_agent
    from poir_mjx.sweep.config import load_sweep_config

    src = Path(cfg.run) / "config.json"
    if not src.is_file():
        raise ConfigError(f"{src}: no such file; expected a sweep run folder (results/<name>/)")
    run_cfg = load_sweep_config(src, recorded=True)
    if run_cfg.observation != "low_dim":  # its names, groups and robosuite episodes are the low-dim set's
        raise ConfigError(f"{src}: field 'observation' is {run_cfg.observation!r}; diagnose takes runs on the "
                          "low_dim observation only")  # fmt: skip
    cells = [cell_index(run_cfg, src, si) for si in cfg.sigma_init]
    if max(cfg.episodes) >= run_cfg.episodes:
        raise ConfigError(f"{SOURCE}: field 'episodes': {max(cfg.episodes)} is not an episode of the cells "
                          f"(field 'episodes' of {src} is {run_cfg.episodes})")  # fmt: skip
    out = Path(cfg.out) if cfg.out is not None else default_out(cfg)
    _mark(out, cfg)
    agent, params, _ = load_run_agent(cfg.run, cfg.task, cfg.method, cfg.seed, cfg.data, cfg.checkpoints, cfg.progress)
    steps = cfg.steps or run_cfg.max_steps
    demo_error, demos = _demo_error(cfg, run_cfg, agent, params)
    for j in cells:
        for e in cfg.episodes:
            path = episode_path(out, cfg, noise_grid(run_cfg)[j][0], e)
            if _readable(path):
                continue
            rec = diagnose_episode(cfg, run_cfg, agent, params, j, e, steps)
            rec["demos"] = demo_error
            rec["provenance"] = {"demos": demos, "command": command_line(), "simulator": simulator_line("robosuite"),
                                 "machine": machine_line(), "stack": stack()}  # fmt: skip
            atomic_write_text(path, json.dumps(rec) + "\n")
            print(f"wrote {path}", file=sys.stderr)
    page = write_page(out, cfg.task)
    print(f"wrote {page}")
    return 0


def _mark(out: Path, cfg: DiagnoseConfig) -> None:
    """<out>/config.json (once): which run the folder diagnoses. Committed, it makes the folder a published one, which
    no command writes again (poir_mjx/outputs.py): a new diagnosis of the same run goes to another --out."""
    marker = out / "config.json"
    if not marker.exists():
        atomic_write_text(marker, json.dumps({"diagnose": str(cfg.run)}) + "\n")  # each record names its command


def episode_path(out: Path, cfg: DiagnoseConfig, si: float, episode: int) -> Path:
    return out / cfg.task / cfg.method / f"si={si:g}_seed={cfg.seed}" / f"episode={episode}.json"


def _readable(path: Path) -> bool:
    try:
        return isinstance(json.loads(path.read_text()).get("calls"), list)
    except (OSError, ValueError, AttributeError):
        return False


def noise_grid(run_cfg) -> list[tuple[float, float]]:
    """The run's noise cells in the order its episode keys follow (sigma_action fastest)."""
    return [(si, sa) for si in run_cfg.sigma_init for sa in run_cfg.sigma_action]


def cell_index(run_cfg, src: Path, si: float) -> int:
    """The cell (sigma_init si, the run's first sigma_action) whose episode keys the forensics use."""
    for j, (s_i, sa) in enumerate(noise_grid(run_cfg)):
        if math.isclose(s_i, si, abs_tol=1e-9) and sa == run_cfg.sigma_action[0]:
            return j
    raise ConfigError(f"{src}: the run has no cell sigma_init {si:g} (field 'sigma_init' {list(run_cfg.sigma_init)})")


def diagnose_episode(cfg: DiagnoseConfig, run_cfg, agent, params, j: int, episode: int, steps: int) -> dict:
    """One episode of cell j (its key, its arm noise; no action noise), the planner taken apart at its snapshots."""
    from tqdm import tqdm

    from poir_mjx.core.ranking import quaternion_free
    from poir_mjx.diagnose import probe, rankings
    from poir_mjx.diagnose.analyze import call_record
    from poir_mjx.diagnose.rankings import ranking_records
    from poir_mjx.diagnose.call_stats import real_rows
    from poir_mjx.diagnose.simulate import Oracle, run_episode
    from poir_mjx.envs.layout import obs_groups
    from poir_mjx.eval.robosuite_eval import episode_streams
    from poir_mjx.rollout.evaluator import episode_keys

    grid = noise_grid(run_cfg)
    si = grid[j][0]
    n_ep = run_cfg.episodes
    key = episode_keys(cfg.seed, len(grid) * n_ep)[j * n_ep + episode][None]
    seeds, step_keys = episode_streams(key, steps)
    policy = probe.plan_fn(agent)
    ep, snaps = run_episode(cfg.task, int(seeds[0]), si, lambda o, k: np.asarray(policy(params, o, k)),
                            np.asarray(step_keys[0]), steps, cfg.every, episode)  # fmt: skip
    call = probe.call_fn(agent)
    true_rewards = probe.true_rewards_fn(agent)
    rank = rankings.scores_fn(agent, quaternion_free(obs_groups(cfg.task)))
    k, _ = agent.head_layout()
    pc = agent.config.planner
    oracle = Oracle(cfg.task, int(seeds[0]), si) if cfg.oracle else None
    calls = []
    try:
        for snap in tqdm(snaps, desc=f"diagnose si={si:g} ep {episode}", unit="call", disable=not cfg.progress):
            c = jax.tree_util.tree_map(np.asarray, call(params, snap.obs, snap.key))
            kw = {}
            if oracle is not None:
                acts_norm = np.stack([real_rows(a, pc.num_trajectories) for a in c["actions"]], 1)  # [N, H, da]
                acts_env = np.asarray(agent._to_env_action(params, acts_norm))
                true_obs = oracle.rollout(snap, acts_env)  # [H + 1, N, ds]
                tr = true_rewards(params, true_obs, np.swapaxes(acts_norm, 0, 1))
                kw["true_returns"] = {r: np.asarray(v).sum(0) for r, v in tr.items()}
                kw["true_first"] = np.asarray(agent.normalize_obs(params, true_obs[1]))
            rec = {"step": snap.step, **call_record(c, k, pc.num_trajectories, pc.top_k, **kw)}
            if oracle is not None:  # every ranking option on the same candidates, judged by the same true returns
                scores = jax.tree_util.tree_map(np.asarray, rank(params, c["states"], c["actions"]))
                rec["rankings"] = ranking_records(scores, kw["true_returns"], k, pc.top_k)
            calls.append(rec)
    finally:
        if oracle is not None:
            oracle.close()
    err = probe.one_step_error_fn(agent)
    ep_err = np.asarray(err(params, ep.obs[:-1], ep.actions, ep.obs[1:])).tolist()
    return {"task": cfg.task, "method": cfg.method, "sigma_init": si, "sigma_action": 0.0, "seed": cfg.seed,
            "episode": episode, "run": str(cfg.run), "success_step": ep.success_step, "steps": len(ep.actions),
            "every": cfg.every, "oracle": cfg.oracle, "simulator": "robosuite", "ensemble_size": k,
            "num_trajectories": pc.num_trajectories, "horizon": pc.horizon, "top_k": pc.top_k,
            "episode_one_step_sq_error": ep_err, "calls": calls}  # fmt: skip


def _demo_error(cfg: DiagnoseConfig, run_cfg, agent, params) -> tuple[dict[str, list[float]], dict]:
    """On the expert demos the world model was trained on (4096 transitions drawn at random), per normalised
    dimension: its one-step squared error ("error") and the expert's own squared one-step change ("change"); and
    the demos' provenance (source, generator, content digest)."""
    from poir_mjx.diagnose import probe
    from poir_mjx.sweep.artifacts import demos_for

    tr, provenance = demos_for(run_cfg, cfg.task, cfg.data, progress=cfg.progress)
    err = probe.one_step_error_fn(agent)
    rows = np.random.default_rng(0).choice(len(tr.obs), min(len(tr.obs), 4096), replace=False)
    change = (agent.normalize_obs(params, tr.next_obs[rows]) - agent.normalize_obs(params, tr.obs[rows])) ** 2
    out = {"error": np.asarray(err(params, tr.obs[rows], tr.actions[rows], tr.next_obs[rows])).tolist(),
           "change": np.asarray(change.mean(0)).tolist()}
    if cfg.holdout > 0:
        out.update(_holdout_error(cfg, agent, params, tr))
    return out, provenance


def _holdout_error(cfg: DiagnoseConfig, agent, params, tr) -> dict[str, list[float]]:
    """A world model trained (same config, same seed) on all demos but the last `holdout` fraction, its one-step
    error on its training demos and on the held-out ones (normalised with its own statistics)."""
    from poir_mjx.diagnose import probe
    from poir_mjx.envs.layout import obs_groups

    n_demos = len(tr.demo_starts)
    held = max(1, round(cfg.holdout * n_demos))
    if held >= n_demos:
        raise ConfigError(f"{SOURCE}: field 'holdout': {cfg.holdout} of {n_demos} demos leaves none to train on")
    cut = int(tr.demo_starts[n_demos - held])
    print(f"diagnose: training a world model on {n_demos - held} of {n_demos} demos (holdout {cfg.holdout:g})",
          file=sys.stderr)  # fmt: skip
    bc = params.bc if agent.config.bc_space == "raw" else None  # the prior is not what is measured: reuse it
    p2, _ = agent.fit(jax.random.PRNGKey(cfg.seed), tr.obs[:cut], tr.actions[:cut], tr.next_obs[:cut],
                      obs_groups=obs_groups(cfg.task), bc_params=bc)  # fmt: skip
    err = probe.one_step_error_fn(agent)
    rng = np.random.default_rng(1)
    train = rng.choice(cut, min(cut, 4096), replace=False)
    test = cut + rng.choice(len(tr.obs) - cut, min(len(tr.obs) - cut, 4096), replace=False)
    return {"holdout_training_error": np.asarray(err(p2, tr.obs[train], tr.actions[train], tr.next_obs[train])).tolist(),
            "holdout_held_out_error": np.asarray(err(p2, tr.obs[test], tr.actions[test], tr.next_obs[test])).tolist()}
