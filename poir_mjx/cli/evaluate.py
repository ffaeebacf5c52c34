"""``eval``: one checkpoint on a noise grid, in MJX, in robosuite, or both side by side (make eval, make xsim)."""

from __future__ import annotations

import math

from poir_mjx import options
from poir_mjx.flags import dotted
from poir_mjx.core.config import ConfigError


def check(opts: options.Eval) -> None:
    for flag, v in (("--episodes", opts.episodes), ("--max-steps", opts.max_steps), ("--workers", opts.workers)):
        if v <= 0:
            raise ConfigError(f"{flag}: must be positive, got {v}")
    for flag, levels in (("--sigma-init", opts.sigma_init), ("--sigma-action", opts.sigma_action)):
        if not all(math.isfinite(x) and x >= 0 for x in levels):
            raise ConfigError(f"{flag}: noise levels must be finite and >= 0")


def evaluate(opts: options.Eval) -> int:
    from poir_mjx.devices import select_device

    check(opts)
    select_device(opts.device, "--device")
    lines = table(opts)
    print("\n".join(lines))
    if opts.out is not None:
        from poir_mjx.atomic import atomic_write_text

        atomic_write_text(opts.out, "\n".join(lines) + "\n")
        print(f"wrote {opts.out}")
    return 0


def planner_config(config, ranking: str, flags: dict, task: str, observation: str):
    """A checkpoint's config as `eval` plans with it: the `ranking`'s planner fields for the task's observation
    (poir_mjx/core/ranking.py), then the --planner flags (which win)."""
    from poir_mjx.core.config import apply_overrides
    from poir_mjx.core.ranking import with_ranking
    from poir_mjx.envs.layout import obs_groups

    config = with_ranking(config, ranking, obs_groups(task, observation=observation))
    return apply_overrides(config, flags, source="command line") if flags else config


def table(opts: options.Eval) -> list[str]:
    import numpy as np

    from poir_mjx.core import checkpoint
    from poir_mjx.core.agent import POIR
    from poir_mjx.envs.layout import OBS_KEYS, obs_groups, observation_named
    from poir_mjx.eval.episodes import SIMULATORS, agreement_p_value, run_episodes
    from poir_mjx.rollout.evaluator import episode_keys
    from poir_mjx.eval.methods import UnknownMethodError, get_method
    from poir_mjx.eval.stats import wilson_interval
    from poir_mjx.versions import simulator_line

    agent, params, layout = checkpoint.load(opts.ckpt)
    task = layout.get("task")
    kind = "poir" if params.wm is not None else "policy"
    method = get_method(opts.method or ("POIR-DRIL" if kind == "poir" else "EBC"))
    if method.online:
        raise UnknownMethodError(
            f"--method: {method.name} fine-tunes in each noise cell during a sweep; use `sweep` with an online config "
            "(e.g. experiments/cpu-small-online.json)"
        )
    if method.agent_kind != kind:
        raise checkpoint.CheckpointError(
            f"{opts.ckpt}: method {method.name} needs a '{method.agent_kind}' checkpoint, this one is '{kind}'"
        )
    observation = observation_named(layout.get("obs_keys", OBS_KEYS))  # what the agent was trained to see
    if observation is None:
        raise checkpoint.CheckpointError(f"{opts.ckpt}: layout field 'obs_keys' {layout.get('obs_keys')!r} is not an "
                                         "observation this version can build (low_dim or object)")  # fmt: skip
    if layout.get("obs_size") != len(obs_groups(task, observation=observation)):
        raise checkpoint.CheckpointError(f"{opts.ckpt}: layout field 'obs_size' does not match task {task}'s "
                                         f"{observation} observation")  # fmt: skip
    flags = dotted(opts.planner, "planner.")
    if flags and method.agent_kind != "poir":
        raise ConfigError(f"--{next(iter(flags))}: method {method.name} does not plan")
    agent = POIR(method.agent_config(planner_config(agent.config, opts.ranking, flags, task, observation)),
                 agent.obs_size, agent.act_size)  # fmt: skip
    n = opts.episodes
    grid = [(si, sa) for si in opts.sigma_init for sa in opts.sigma_action]
    si = np.repeat([g[0] for g in grid], n)
    sa = np.repeat([g[1] for g in grid], n)
    keys = episode_keys(opts.seed, len(si))
    sims = list(SIMULATORS) if opts.simulator == "both" else [opts.simulator]
    steps, workers = opts.max_steps, opts.workers
    res = {sim: run_episodes(sim, task, method, agent, params, keys, si, sa, steps, workers, True, observation,
                             opts.physics) for sim in sims}  # fmt: skip
    data = layout.get("demos", {})
    planner = f"; ranking {opts.ranking}" * (method.act == "plan") + "".join(f"; {k}={v}" for k, v in flags.items())
    lines = [f"{task}, {method.name}, checkpoint {opts.ckpt}{planner}; expert data: {data.get('source', '?')} "
             f"({data.get('simulator', data.get('path', '?'))}); {n} episodes x {opts.max_steps} steps per "
             f"cell, seed {opts.seed} (the sweep's episode keys); simulator: "
             + " vs ".join(simulator_line(sim) + (f" ({opts.physics} physics)" if sim == "mjx" else "")
                           for sim in sims), "",  # fmt: skip
             "| sigma_init | sigma_action | " + " | ".join(f"{sim}: success [Wilson 95%] (diverged)" for sim in sims)
             + (" | Fisher p |" if len(sims) == 2 else " |"),
             "|---|---|" + "---|" * (len(sims) + (len(sims) == 2))]  # fmt: skip
    for j, (a, b) in enumerate(grid):
        cells, counts = [], []
        for sim in sims:
            ok = res[sim]["first_success"][j * n : (j + 1) * n] >= 0
            lo, hi = wilson_interval(int(ok.sum()), n)
            dv = int(res[sim]["diverged"][j * n : (j + 1) * n].sum())
            cells.append(f"{ok.mean():.2f} [{lo:.2f}, {hi:.2f}] ({dv})")
            counts.append(int(ok.sum()))
        if len(sims) == 2:
            cells.append(f"{agreement_p_value(counts[0], n, counts[1], n):.2f}")
        lines.append(f"| {a:g} | {b:g} | " + " | ".join(cells) + " |")
    return lines
