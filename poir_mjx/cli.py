"""poir-mjx command line: ``python -m poir_mjx.cli <command>``.

    sweep --config experiments/cpu-small.json     success rate versus noise (make sweep)
    eval --ckpt PATH [--sigma-init ...]            evaluate one checkpoint (make eval CKPT=...)
    envs / bench-env / bench-planner / demos       the other make targets
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path


def _eval(args) -> int:
    import numpy as np

    from poir_mjx.core import checkpoint
    from poir_mjx.core.agent import POIR
    from poir_mjx.envs.layout import obs_groups
    from poir_mjx.eval.methods import UnknownMethodError, get_method
    from poir_mjx.atomic import atomic_write_text
    from poir_mjx.eval.episodes import SIMULATORS, agreement_p_value, run_episodes
    from poir_mjx.eval.evaluator import episode_keys
    from poir_mjx.eval.stats import wilson_interval
    from poir_mjx.versions import simulator_line

    agent, params, layout = checkpoint.load(args.ckpt)
    task = layout.get("task")
    kind = "poir" if params.wm is not None else "policy"
    method = get_method(args.method or ("POIR-DRIL" if kind == "poir" else "EBC"))
    if method.online:
        raise UnknownMethodError(
            f"--method: {method.name} fine-tunes in each noise cell during a sweep; use `sweep` with an online config "
            "(e.g. experiments/cpu-small-online.json)"
        )
    if method.agent_kind != kind:
        raise checkpoint.CheckpointError(
            f"{args.ckpt}: method {method.name} needs a '{method.agent_kind}' checkpoint, this one is '{kind}'"
        )
    if layout.get("obs_size") != len(obs_groups(task)):
        raise checkpoint.CheckpointError(f"{args.ckpt}: layout field 'obs_size' does not match task {task}")
    agent = POIR(method.agent_config(agent.config), agent.obs_size, agent.act_size)
    grid = [(si, sa) for si in args.sigma_init for sa in args.sigma_action]
    si = np.repeat([g[0] for g in grid], args.episodes)
    sa = np.repeat([g[1] for g in grid], args.episodes)
    keys = episode_keys(args.seed, len(si))
    sims = list(SIMULATORS) if args.simulator == "both" else [args.simulator]
    res = {sim: run_episodes(sim, task, method, agent, params, keys, si, sa, args.max_steps, args.workers) for sim in sims}
    data = layout.get("demos", {})
    lines = [f"{task}, {method.name}, checkpoint {args.ckpt}; expert data: {data.get('source', '?')} "
             f"({data.get('simulator', data.get('path', '?'))}); {args.episodes} episodes x {args.max_steps} steps per "
             f"cell, seed {args.seed} (the sweep's episode keys); simulator: "
             + " vs ".join(simulator_line(sim) for sim in sims), "",
             "| sigma_init | sigma_action | " + " | ".join(f"{sim}: success [Wilson 95%] (diverged)" for sim in sims)
             + (" | Fisher p |" if len(sims) == 2 else " |"), "|---|---|" + "---|" * (len(sims) + (len(sims) == 2))]  # fmt: skip
    for j, (a, b) in enumerate(grid):
        cells, counts = [], []
        for sim in sims:
            ok = res[sim]["first_success"][j * args.episodes : (j + 1) * args.episodes] >= 0
            lo, hi = wilson_interval(int(ok.sum()), args.episodes)
            dv = int(res[sim]["diverged"][j * args.episodes : (j + 1) * args.episodes].sum())
            cells.append(f"{ok.mean():.2f} [{lo:.2f}, {hi:.2f}] ({dv})")
            counts.append(int(ok.sum()))
        if len(sims) == 2:
            cells.append(f"{agreement_p_value(counts[0], args.episodes, counts[1], args.episodes):.2f}")
        lines.append(f"| {a:g} | {b:g} | " + " | ".join(cells) + " |")
    print("\n".join(lines))
    if args.out is not None:
        atomic_write_text(args.out, "\n".join(lines) + "\n")
        print(f"wrote {args.out}")
    return 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="poir-mjx", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="command", required=True)
    sub.add_parser("envs", help="export the robosuite tasks to envs/ (make envs)")
    sub.add_parser("bench-env", help="MJX vs robosuite throughput (make bench-env)")
    sub.add_parser("bench-planner", help="planner throughput (make bench-planner)")
    sub.add_parser("demos", help="scripted-expert demonstrations (make demos)")
    sp = sub.add_parser("sweep", help="success rate versus noise over a grid (make sweep)")
    sp.add_argument("--config", required=True, type=Path, help="sweep config file (experiments/*.json)")
    sp.add_argument("--results", type=Path, default=Path("results"))
    sp.add_argument("--data", type=Path, default=Path("data/demos"))
    sp.add_argument("--checkpoints", type=Path, default=Path("checkpoints"))
    sp.add_argument("--replace-config", action="store_true",
                    help="run a changed config in an existing run folder (cells made with other settings are recomputed)")
    cp = sub.add_parser("compare", help="one table across sweep runs, e.g. ablations (make ablations)")
    cp.add_argument("runs", type=Path, nargs="+", help="run folders (results/<name>)")
    cp.add_argument("--out", type=Path, default=None, help="also write the table to this file (markdown)")
    ep = sub.add_parser("eval", help="evaluate a checkpoint on a noise grid (make eval CKPT=...)")
    ep.add_argument("--ckpt", required=True, type=Path)
    ep.add_argument("--method", default=None, help="default: EBC for a policy checkpoint, POIR-DRIL for a POIR one")
    ep.add_argument("--sigma-init", type=float, nargs="+", default=[0.02, 0.1, 0.2, 0.3, 0.4])
    ep.add_argument("--sigma-action", type=float, nargs="+", default=[0.0])
    ep.add_argument("--episodes", type=int, default=10)
    ep.add_argument("--max-steps", type=int, default=400)
    ep.add_argument("--seed", type=int, default=0)
    ep.add_argument("--device", default="any", choices=["any", "cpu", "gpu"], help="gpu: fail unless jax sees a GPU")
    ep.add_argument("--simulator", default="mjx", choices=["mjx", "robosuite", "both"],
                    help="mjx (vectorised), robosuite (the reference simulator, in --workers processes) or both "
                    "side by side with a Fisher exact test per cell (make xsim)")
    ep.add_argument("--workers", type=int, default=2, help="robosuite worker processes")
    ep.add_argument("--out", type=Path, default=None, help="also write the table to this file (markdown)")
    args, rest = p.parse_known_args(argv)

    from poir_mjx.core.checkpoint import CheckpointError
    from poir_mjx.core.config import ConfigError
    from poir_mjx.data.robomimic import DatasetError
    from poir_mjx.envs.env import ModelFileError
    from poir_mjx.envs.tasks import UnknownTaskError
    from poir_mjx.eval.methods import UnknownMethodError
    from poir_mjx.devices import DeviceError, select_device
    from poir_mjx.optional import MissingDependencyError

    try:
        if args.command == "envs":
            from poir_mjx.envs.export import main as m

            return m(rest)
        if args.command == "bench-env":
            from poir_mjx.bench.env import main as m

            return m(rest)
        if args.command == "bench-planner":
            from poir_mjx.bench.planner import main as m

            return m(rest)
        if args.command == "demos":
            from poir_mjx.data.demos import main as m

            return m(rest or ["generate"])
        if rest:
            p.error(f"unrecognised arguments: {' '.join(rest)}")
        if args.command == "compare":
            from poir_mjx.eval.compare import main as compare_main

            return compare_main(args.runs, args.out)
        if args.command == "eval":
            if args.episodes <= 0 or args.max_steps <= 0 or args.workers <= 0:
                raise ConfigError("--episodes, --max-steps and --workers must be positive")
            if not all(math.isfinite(x) and x >= 0 for x in args.sigma_init + args.sigma_action):
                raise ConfigError("--sigma-init/--sigma-action: noise levels must be finite and >= 0")
            select_device(args.device, "--device")
            return _eval(args)
        from poir_mjx.eval.sweep import load_sweep_config, run_sweep

        cfg = load_sweep_config(args.config)
        import jax

        select_device(cfg.device, f"{args.config}: field 'device'")
        jax.config.update("jax_enable_x64", cfg.x64)  # before any array exists
        out = run_sweep(cfg, args.results, args.data, args.checkpoints, replace_config=args.replace_config)
        print((out / "summary.md").read_text())
        print(f"sweep {cfg.name}: tables in {out}/ (summary.md, <task>.md/.csv/.png)")
        return 0
    except (ConfigError, CheckpointError, DatasetError, ModelFileError, UnknownTaskError, UnknownMethodError,
            MissingDependencyError, DeviceError) as e:  # fmt: skip
        print(f"error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
