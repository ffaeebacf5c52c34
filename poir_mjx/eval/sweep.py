"""Noise sweeps: tasks x methods x (sigma_init, sigma_action) grid x seeds, resumable, atomic.

    python -m poir_mjx.cli sweep --config experiments/cpu-small.json

Layout of ``results/<name>/``:
    cells/<task>/<method>/si=<s>_sa=<a>_seed=<k>.json   one record per cell (written atomically)
    <task>.md, <task>.csv, <task>.png                   success rate versus noise
    <task>-online.png                                   learning curves of the online methods
    summary.md                                          all tables, data provenance, config
An online method ("POIR-<reward> online") fine-tunes its world model in each cell's perturbed
environment (poir_mjx/online), checkpointing after every round under
checkpoints/<task>/online/; its cell holds the success after fine-tuning and the learning curve.
A cell whose record exists with the same config hash is never recomputed, so a sweep killed at
any moment and started again with the same command finishes with the same tables.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import math
import time
import typing
from pathlib import Path

import jax
import numpy as np

from poir_mjx.atomic import atomic_write_text
from poir_mjx.core import checkpoint
from poir_mjx.core.agent import POIR
from poir_mjx.core.config import ConfigError, POIRConfig, apply_overrides, check_fields, preset, to_dict
from poir_mjx.data.robomimic import LOW_DIM_KEYS, DatasetError, read_transitions
from poir_mjx.envs.env import make_env, make_params
from poir_mjx.envs.layout import obs_groups
from poir_mjx.envs.tasks import TASKS
from poir_mjx.eval.methods import METHODS, Method, get_method
from poir_mjx.eval import run_folder
from poir_mjx.eval.episodes import run_episodes
from poir_mjx.eval.run_folder import check_run_name
from poir_mjx.eval.rollout import episode_keys
from poir_mjx.eval.stats import wilson_interval
from poir_mjx.versions import simulator_line


@dataclasses.dataclass(frozen=True)
class SweepConfig:
    name: str
    """Run name: results go to results/<name>/."""
    preset: str = "cpu-small"
    """POIR config preset (cpu-small, paper)."""
    tasks: tuple[str, ...] = ("lift",)
    """Tasks to evaluate."""
    methods: tuple[str, ...] = ("EBC", "POIR-DRIL")
    """Methods from the registry (BC, EBC, POIR-L2, POIR-DRIL, POIR-MOREL, POIR-noprior)."""
    sigma_init: tuple[float, ...] = (0.02, 0.2, 0.4)
    """Initial arm-joint noise levels."""
    sigma_action: tuple[float, ...] = (0.0,)
    """Action noise levels."""
    seeds: tuple[int, ...] = (0,)
    """Training and evaluation seeds."""
    episodes: int = 10
    """Episodes per cell."""
    max_steps: int = 400
    """Control steps per episode (robosuite's horizon is 400)."""
    num_demos: int = 200
    """Scripted-expert demonstrations per task (ignored for tasks given in demo_files)."""
    demo_simulator: str = "robosuite"
    """Where the scripted expert records its demos: "robosuite" (MuJoCo C, needs robosuite) or "mjx"
    (vectorised in MJX, no robosuite: the path for a GPU machine)."""
    demo_batch: int = 16
    """MJX episodes per compiled batch when demo_simulator is "mjx" (GPU: 256-1024)."""
    simulator: str = "mjx"
    """Where the evaluation episodes run: "mjx" (vectorised, one compiled rollout: the GPU path) or
    "robosuite" (the reference: robosuite's own environment and controller in `workers` processes,
    the agent's calls batched across them; needs robosuite; online methods fine-tune in MJX only)."""
    workers: int = 2
    """robosuite worker processes when simulator is "robosuite" (about one per CPU core)."""
    device: str = "any"
    """"gpu" refuses to run unless jax sees a GPU (no silent CPU run), "cpu" forces the CPU, "any" takes jax's default."""
    demo_files: dict = dataclasses.field(default_factory=dict)
    """Optional {task: path} of robomimic HDF5 files to use instead of the scripted expert."""
    epochs: int = 0
    """If > 0, overrides the preset's training epochs."""
    overrides: dict = dataclasses.field(default_factory=dict)
    """Dotted POIR config fields replacing the preset's values, e.g. {"online.total_env_steps": 20000}."""
    x64: bool = False
    """MJX physics in float64 (float32 once launched Square's nut mid-grasp); networks and planner stay float32."""


def load_sweep_config(path: str | Path) -> SweepConfig:
    """Parse and validate a sweep config file; errors name the file and the field."""
    path = Path(path)
    try:
        raw = json.loads(path.read_text())
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such config file") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, expected a sweep config file (JSON)") from None
    except json.JSONDecodeError as e:
        raise ConfigError(f"{path}: not valid JSON ({e})") from None
    if not isinstance(raw, dict):
        raise ConfigError(f"{path}: expected a JSON object")
    check_fields(raw, SweepConfig, str(path))
    hints = typing.get_type_hints(SweepConfig)
    kw = {}
    for k, v in raw.items():
        t = hints[k]
        if typing.get_origin(t) is tuple:
            if not isinstance(v, list) or not v:
                raise ConfigError(f"{path}: field '{k}' must be a non-empty list")
            item = typing.get_args(t)[0]
            for x in v:
                ok = isinstance(x, str) if item is str else (isinstance(x, (int, float)) and not isinstance(x, bool))
                if item is int:
                    ok = isinstance(x, int) and not isinstance(x, bool)
                if not ok:
                    raise ConfigError(f"{path}: field '{k}' has a {type(x).__name__} item {x!r}, expected {item.__name__}")
            v = tuple(v)
        elif t is bool and not isinstance(v, bool):
            raise ConfigError(f"{path}: field '{k}' must be true or false, got {v!r}")
        elif t is int and (not isinstance(v, int) or isinstance(v, bool)):
            raise ConfigError(f"{path}: field '{k}' must be an integer, got {v!r}")
        elif t is str and not isinstance(v, str):
            raise ConfigError(f"{path}: field '{k}' must be a string, got {v!r}")
        elif t is dict and not isinstance(v, dict):
            raise ConfigError(f"{path}: field '{k}' must be an object")
        kw[k] = v
    if "name" not in kw:
        raise ConfigError(f"{path}: field 'name' is required")
    check_run_name(kw["name"], str(path))
    cfg = SweepConfig(**kw)
    for t in cfg.tasks:
        if t not in TASKS:
            raise ConfigError(f"{path}: field 'tasks': unknown task {t!r}; expected one of {', '.join(TASKS)}")
    for m in cfg.methods:
        if m not in METHODS:
            raise ConfigError(f"{path}: field 'methods': unknown method {m!r}; expected one of {', '.join(METHODS)}")
    for fld in ("sigma_init", "sigma_action"):
        if not all(math.isfinite(x) and x >= 0 for x in getattr(cfg, fld)):
            raise ConfigError(f"{path}: field '{fld}': noise levels must be finite and >= 0")
    if cfg.demo_simulator not in ("robosuite", "mjx"):
        raise ConfigError(f"{path}: field 'demo_simulator' must be \"robosuite\" or \"mjx\", got {cfg.demo_simulator!r}")
    if cfg.simulator not in ("mjx", "robosuite"):
        raise ConfigError(f"{path}: field 'simulator' must be \"mjx\" or \"robosuite\", got {cfg.simulator!r}")
    if cfg.simulator == "robosuite" and any(get_method(m).online for m in cfg.methods):
        raise ConfigError(f"{path}: field 'simulator': online methods fine-tune and evaluate in MJX; use \"mjx\"")
    if cfg.device not in ("any", "cpu", "gpu"):
        raise ConfigError(f"{path}: field 'device' must be \"any\", \"cpu\" or \"gpu\", got {cfg.device!r}")
    for fld in ("episodes", "max_steps", "num_demos", "demo_batch", "workers"):
        if getattr(cfg, fld) <= 0:
            raise ConfigError(f"{path}: field '{fld}' must be positive")
    if cfg.epochs < 0:
        raise ConfigError(f"{path}: field 'epochs' must be positive (or 0: the preset's), got {cfg.epochs}")
    try:
        preset(cfg.preset)
    except ConfigError as e:
        raise ConfigError(f"{path}: field 'preset': {e}") from None
    try:
        base_config(cfg)
    except ConfigError as e:
        raise ConfigError(f"{path}: field {e}") from None
    for task, f in cfg.demo_files.items():
        if task not in TASKS:
            raise ConfigError(f"{path}: field 'demo_files': unknown task {task!r}")
        if task not in cfg.tasks:
            raise ConfigError(f"{path}: field 'demo_files': task {task!r} is not in field 'tasks'")
        if Path(f).is_dir():
            raise ConfigError(f"{path}: field 'demo_files.{task}': {f} is a directory, expected a robomimic HDF5 file")
        if not Path(f).is_file():
            raise ConfigError(f"{path}: field 'demo_files.{task}': no such file {f}")
    return cfg


def base_config(cfg: SweepConfig) -> POIRConfig:
    base = preset(cfg.preset)
    if cfg.epochs:
        base = dataclasses.replace(base, train=dataclasses.replace(base.train, epochs=cfg.epochs))
    return apply_overrides(base, cfg.overrides) if cfg.overrides else base


def _config_dict(cfg: POIRConfig, online: bool) -> dict:
    """The config as hashed: offline agents and cells do not depend on the online settings."""
    d = to_dict(cfg)
    if not online:
        d.pop("online")
    return d


def _hash(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()[:16]


# ---------------------------------------------------------------------------------- data / training
def demos_for(cfg: SweepConfig, task: str, data_dir: Path, progress: bool = True) -> tuple[Path, dict]:
    """The demo file for `task` (made on first use) and its provenance, with a digest of its content
    ("sha256": the transitions the agents train on), which keys the checkpoints and the cells."""
    if task in cfg.demo_files:
        path = Path(cfg.demo_files[task])
        return path, {"source": "file", "path": str(path), "sha256": content_digest(path, task)}
    from poir_mjx.data.demos import generate

    path = generate(task, cfg.num_demos, seed=0, sigma_init=0.02, out=data_dir, simulator=cfg.demo_simulator,
                    batch=cfg.demo_batch, progress=progress)  # fmt: skip
    tr = read_transitions(path, task=task, max_demos=1)
    generator = tr.provenance.get("poir_mjx_generator", {})
    if not isinstance(generator, dict):
        raise DatasetError(f"{path}: field data.attrs['poir_mjx_generator'] is not a JSON object")
    return path, {"source": "scripted expert", **generator,
                  "sha256": content_digest(path, task)}  # fmt: skip


def content_digest(path: Path, task: str) -> str:
    """sha256 of the demos' names and (obs, actions, next_obs) as read for training: a replaced or
    corrupted file at the same path gives another digest, a byte-different copy of the same data not."""
    tr = read_transitions(path, task=task)
    h = hashlib.sha256(json.dumps([tr.demo_names, list(tr.obs_keys)]).encode())
    for a in (tr.obs, tr.actions, tr.next_obs):
        h.update(np.ascontiguousarray(a, np.float32).tobytes())
    return h.hexdigest()[:16]


def train_or_load(method: Method, cfg: SweepConfig, task: str, seed: int, demo_path: Path, provenance: dict,
                  ckpt_dir: Path, progress: bool = True):  # fmt: skip
    """The trained agent for (method's kind, task, seed), from its checkpoint if one matches."""
    from tqdm import tqdm

    tcfg = method.training_config(base_config(cfg))
    layout = {"task": task, "obs_keys": list(LOW_DIM_KEYS), "seed": seed, "demos": provenance}
    key = _hash([_config_dict(tcfg, online=False), layout])
    path = ckpt_dir / task / f"{method.agent_kind}-seed{seed}-{key}.ckpt"
    if path.exists():
        agent, params, _ = checkpoint.load(path, tcfg, layout)
    else:
        tr = read_transitions(demo_path, task=task)
        groups = obs_groups(task)
        if tr.obs.shape[1] != len(groups):
            raise DatasetError(f"{demo_path}: observations {list(LOW_DIM_KEYS)} are {tr.obs.shape[1]} wide, "
                               f"task {task} has {len(groups)}")  # fmt: skip
        agent = POIR(tcfg, tr.obs.shape[1], tr.actions.shape[1])
        bar = tqdm(total=tcfg.train.epochs * (2 if method.agent_kind == "poir" else 1),
                   desc=f"train {task} {method.agent_kind} seed {seed}", unit="epoch", disable=not progress)  # fmt: skip

        def cb(name, epoch, loss):
            bar.update(1)
            bar.set_postfix({name: f"{float(np.mean(loss)):.4f}"})

        params, _ = agent.fit(jax.random.PRNGKey(seed), tr.obs, tr.actions, tr.next_obs, obs_groups=groups,
                              train_world_model=method.agent_kind == "poir", callback=cb)  # fmt: skip
        bar.close()
        checkpoint.save(path, agent, params, layout)
    return POIR(method.agent_config(base_config(cfg)), agent.obs_size, agent.act_size), params, path


# ---------------------------------------------------------------------------------- cells
def cell_path(out: Path, task: str, method: str, si: float, sa: float, seed: int) -> Path:
    return out / "cells" / task / method / f"si={si:g}_sa={sa:g}_seed={seed}.json"


def cell_hash(cfg: SweepConfig, task: str, method: str, demo_sha256: str) -> str:
    relevant = {
        "demo_sha256": demo_sha256,
        "preset": _config_dict(get_method(method).agent_config(base_config(cfg)), get_method(method).online),
        "episodes": cfg.episodes,
        "max_steps": cfg.max_steps,
        "num_demos": cfg.num_demos,
        "demo_file": cfg.demo_files.get(task),
        **({"demo_simulator": cfg.demo_simulator} if cfg.demo_simulator != "robosuite" else {}),
        **({"simulator": cfg.simulator} if cfg.simulator != "mjx" else {}),
        "x64": cfg.x64,
    }
    return _hash(relevant)


def read_cell(path: Path, chash: str) -> dict | None:
    """The cell's record if it was made with config hash `chash`; None if absent or from another config."""
    try:
        rec = json.loads(path.read_text())
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ConfigError(f"{path}: not a readable cell record ({e}); delete it to recompute the cell") from None
    if not isinstance(rec, dict):
        raise ConfigError(f"{path}: not a cell record (expected a JSON object); delete it to recompute the cell")
    return rec if rec.get("config_hash") == chash else None


def run_sweep(cfg: SweepConfig, results_root: Path = Path("results"), data_dir: Path = Path("data/demos"),
              ckpt_dir: Path = Path("checkpoints"), progress: bool = True, replace_config: bool = False) -> Path:  # fmt: skip
    from tqdm import tqdm

    out = results_root / check_run_name(cfg.name, "sweep config")
    run_folder.prepare(out, dataclasses.asdict(cfg), replace_config)  # before any work: writable, one config
    grid = [(si, sa) for si in cfg.sigma_init for sa in cfg.sigma_action]
    cells = [(t, m, s) for t in cfg.tasks for m in cfg.methods for s in cfg.seeds]
    total_eps = len(cells) * len(grid) * cfg.episodes
    bar = tqdm(total=total_eps, desc=f"sweep {cfg.name}", unit="ep", disable=not progress)
    t_start, done_now = time.perf_counter(), 0
    demos = {task: demos_for(cfg, task, data_dir, progress) for task in cfg.tasks}  # (path, provenance)
    digests = {task: prov["sha256"] for task, (_, prov) in demos.items()}
    for task, mname, seed in cells:
        method = get_method(mname)
        chash = cell_hash(cfg, task, mname, digests[task])
        paths = [cell_path(out, task, mname, si, sa, seed) for si, sa in grid]
        if all(read_cell(p, chash) for p in paths):
            bar.update(len(grid) * cfg.episodes)
            continue
        demo_path, prov = demos[task]
        agent, params, ckpt = train_or_load(method, cfg, task, seed, demo_path, prov, ckpt_dir, progress)
        si = np.repeat([g[0] for g in grid], cfg.episodes)
        sa = np.repeat([g[1] for g in grid], cfg.episodes)
        keys = episode_keys(seed, len(si))  # one key per episode
        common = {"task": task, "method": mname, "seed": seed, "episodes": cfg.episodes, "max_steps": cfg.max_steps,
                  "config_hash": chash, "checkpoint": str(ckpt), "data": prov,
                  "device": f"{jax.devices()[0].platform} x{jax.device_count()}", "x64": bool(jax.config.jax_enable_x64),
                  "simulator": simulator_line(cfg.simulator)}  # fmt: skip
        if method.online:
            # Each noise cell is its own deployment environment: fine-tune there, evaluate on the
            # cell's own episode keys (the offline cell's keys: a paired comparison).
            tr = read_transitions(demo_path, task=task)  # the expert half of every batch, read once
            offline = (tr.obs, tr.actions, tr.next_obs)
            for j, ((s_i, s_a), path) in enumerate(zip(grid, paths)):
                if read_cell(path, chash):
                    bar.update(cfg.episodes)
                    continue
                sl = slice(j * cfg.episodes, (j + 1) * cfg.episodes)
                t0 = time.perf_counter()
                slug = mname.replace(" ", "_")
                ckpt_path = ckpt_dir / task / "online" / f"{slug}-si={s_i:g}_sa={s_a:g}_seed={seed}-{chash}.ckpt"
                res = run_online_cell(cfg, task, agent, params, offline, s_i, s_a, seed, keys[sl], ckpt_path,
                                      chash, progress)  # fmt: skip
                final = res.curve[-1]
                rec = _cell_record(common, s_i, s_a, final["successes"], final["diverged"], None,
                                   time.perf_counter() - t0)  # fmt: skip
                rec.update(curve=res.curve, rounds=res.rounds, online=to_dict(agent.config.online),
                           resumed_from_round=res.resumed_from_round, online_checkpoint=str(ckpt_path))  # fmt: skip
                atomic_write_text(path, json.dumps(rec, indent=2) + "\n")
                done_now += cfg.episodes
                bar.update(cfg.episodes)
            continue
        t0 = time.perf_counter()
        res = run_episodes(cfg.simulator, task, method, agent, params, keys, si, sa, cfg.max_steps, cfg.workers,
                           progress)  # fmt: skip
        wall = time.perf_counter() - t0
        for j, ((s_i, s_a), path) in enumerate(zip(grid, paths)):
            sl = slice(j * cfg.episodes, (j + 1) * cfg.episodes)
            first = res["first_success"][sl]
            rec = _cell_record(common, s_i, s_a, int((first >= 0).sum()), int(res["diverged"][sl].sum()),
                               np.where(first >= 0, first, cfg.max_steps), wall / len(grid))  # fmt: skip
            atomic_write_text(path, json.dumps(rec, indent=2) + "\n")
        done_now += len(si)
        bar.update(len(si))
        bar.set_postfix(eps_per_s=f"{done_now / (time.perf_counter() - t_start):.2f}")
    bar.close()
    write_tables(cfg, out, digests)
    return out


def _cell_record(common: dict, si: float, sa: float, k: int, diverged: int, lengths, wall: float) -> dict:
    n = common["episodes"]
    lo, hi = wilson_interval(k, n)
    rec = {**common, "sigma_init": si, "sigma_action": sa, "successes": k, "success_rate": k / n, "wilson95": [lo, hi],
           "diverged": diverged, "wall_s": wall}  # fmt: skip
    if lengths is not None:
        rec["mean_episode_length"] = float(np.mean(lengths))
    return rec


def run_online_cell(cfg: SweepConfig, task: str, agent: POIR, params, offline: tuple, si: float, sa: float,
                    seed: int, eval_keys, ckpt_path: Path, chash: str, progress: bool):  # fmt: skip
    """Online fine-tuning in the cell's environment (resumes from `ckpt_path`), evaluated on `eval_keys`.

    offline: the expert transitions (obs, actions, next_obs) the agent was trained on.
    """
    trainer = _online_trainer(task, agent, cfg.max_steps)
    key = jax.random.PRNGKey(seed)
    for x in (2, round(si * 1e6), round(sa * 1e6)):  # the cell's own stream: collection and training keys
        key = jax.random.fold_in(key, x)
    return trainer.run(params, offline, make_params(si, sa), eval_keys, key,
                       checkpoint_path=ckpt_path, config_hash=chash, progress=progress)  # fmt: skip


@functools.lru_cache(maxsize=None)
def _online_trainer(task: str, agent: POIR, steps: int):
    from poir_mjx.online.loop import OnlineTrainer

    return OnlineTrainer(make_env(task), agent, steps)


# ---------------------------------------------------------------------------------- tables
def collect(cfg: SweepConfig, out: Path, task: str, digest: str) -> dict:
    table = {}
    for mname in cfg.methods:
        chash = cell_hash(cfg, task, mname, digest)
        for si in cfg.sigma_init:
            for sa in cfg.sigma_action:
                recs = [read_cell(cell_path(out, task, mname, si, sa, s), chash) for s in cfg.seeds]
                recs = [r for r in recs if r]
                if recs:
                    k = sum(r["successes"] for r in recs)
                    n = sum(r["episodes"] for r in recs)
                    table[(mname, si, sa)] = {"k": k, "n": n, "ci": wilson_interval(k, n), "data": recs[0]["data"],
                                              "diverged": sum(r["diverged"] for r in recs),
                                              "simulator": recs[0].get("simulator", "MJX")}  # fmt: skip
    return table


def _col(si, sa, cfg):
    return f"σ_init {si:g}" + (f", σ_act {sa:g}" if len(cfg.sigma_action) > 1 or sa else "")


def write_tables(cfg: SweepConfig, out: Path, digests: dict[str, str]) -> str:
    """Tables and plots of the cells made with the demo data whose content digest is `digests[task]`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sections = []
    for task in cfg.tasks:
        table = collect(cfg, out, task, digests[task])
        if not table:
            continue
        data = next(iter(table.values()))["data"]
        src = (f"scripted expert ({data.get('expert', '?')}, {data.get('simulator', '?')}, "
               f"{data.get('num_demos', '?')} demos)" if data.get("source") == "scripted expert"
               else f"robomimic file {data.get('path')}")  # fmt: skip
        cols = [(si, sa) for si in cfg.sigma_init for sa in cfg.sigma_action]
        md = [f"## {task}", "", f"Success rate (Wilson 95% interval), {cfg.episodes} episodes x {len(cfg.seeds)} seed(s) per cell, "
              f"{cfg.max_steps} steps per episode, preset {cfg.preset}. Expert data: {src}. "
              f"Simulator: {next(iter(table.values()))['simulator']}.", "",
              "| method | " + " | ".join(_col(si, sa, cfg) for si, sa in cols) + " |",
              "|---|" + "---|" * len(cols)]  # fmt: skip
        csv = ["method," + ",".join(f"si={si:g} sa={sa:g} {x}" for si, sa in cols for x in ("rate", "lo", "hi"))]
        for m in cfg.methods:
            cells, row = [], []
            for si, sa in cols:
                c = table.get((m, si, sa))
                if c is None:
                    cells.append("-"), row.extend(["", "", ""])
                else:
                    div = f" ({c['diverged']} diverged)" if c["diverged"] else ""
                    cells.append(f"{c['k'] / c['n']:.2f} [{c['ci'][0]:.2f}, {c['ci'][1]:.2f}]{div}")
                    row.extend([f"{c['k'] / c['n']:.4f}", f"{c['ci'][0]:.4f}", f"{c['ci'][1]:.4f}"])
            md.append(f"| {m} | " + " | ".join(cells) + " |")
            csv.append(m + "," + ",".join(row))
        md_text = "\n".join(md) + "\n"
        atomic_write_text(out / f"{task}.md", md_text)
        atomic_write_text(out / f"{task}.csv", "\n".join(csv) + "\n")
        fig, ax = plt.subplots(figsize=(5, 3.5))
        for m in cfg.methods:
            for sa in cfg.sigma_action:
                xs = [si for si in cfg.sigma_init if (m, si, sa) in table]
                if not xs:
                    continue
                ys = [table[(m, si, sa)]["k"] / table[(m, si, sa)]["n"] for si in xs]
                err = np.array([[y - table[(m, si, sa)]["ci"][0], table[(m, si, sa)]["ci"][1] - y] for si, y in zip(xs, ys)]).T
                err = np.maximum(err, 0.0)
                label = m if len(cfg.sigma_action) == 1 else f"{m} σ_act {sa:g}"
                ax.errorbar(xs, ys, yerr=err, marker="o", capsize=3, label=label)
        ax.set_xlabel("σ_init (initial joint noise)")
        ax.set_ylabel("success rate")
        ax.set_ylim(-0.05, 1.05)
        ax.set_title(f"{task} ({cfg.preset})")
        ax.legend(fontsize=8)
        _save_png(fig, out / f"{task}.png")
        section = md_text + f"\n![{task}]({task}.png)\n"
        curves = write_learning_curves(cfg, out, task, digests[task])
        if curves:
            atomic_write_text(out / f"{task}.md", md_text + "\n" + curves)
            section += "\n" + curves + f"\n![{task} online]({task}-online.png)\n"
        sections.append(section)
    summary = "\n".join([f"# Sweep {cfg.name}", "", "Config:", "", "```json",
                         json.dumps(dataclasses.asdict(cfg), indent=2), "```", ""] + sections)  # fmt: skip
    atomic_write_text(out / "summary.md", summary)
    return summary


def write_learning_curves(cfg: SweepConfig, out: Path, task: str, digest: str) -> str:
    """Markdown table and `<task>-online.png` of the online methods' curves ("" if there are none)."""
    import matplotlib.pyplot as plt

    rows, lines = [], []
    for m in (m for m in cfg.methods if get_method(m).online):
        chash = cell_hash(cfg, task, m, digest)
        for si in cfg.sigma_init:
            for sa in cfg.sigma_action:
                recs = [read_cell(cell_path(out, task, m, si, sa, s), chash) for s in cfg.seeds]
                recs = [r for r in recs if r]
                if not recs:
                    continue
                steps = [c["env_steps"] for c in recs[0]["curve"]]
                k = np.sum([[c["successes"] for c in r["curve"]] for r in recs], 0)
                n = np.sum([[c["episodes"] for c in r["curve"]] for r in recs], 0)
                r_steps = [x["env_steps"] for x in recs[0]["rounds"]]
                err = np.mean([[x["wm_error"] for x in r["rounds"]] for r in recs], 0)
                err_off = np.mean([[x["wm_error_offline"] for x in r["rounds"]] for r in recs], 0)
                label = f"{m}, {_col(si, sa, cfg)}"
                lines.append((label, steps, k / n, r_steps, err, err_off))
                rows.append(f"| {label} | " + "; ".join(f"{int(x):,}: {a}/{b}" for x, a, b in zip(steps, k, n))
                            + f" | {err[0]:.3g} → {err[-1]:.3g} (offline model {err_off[-1]:.3g}) |")  # fmt: skip
    if not rows:
        return ""
    oc = get_method(next(m for m in cfg.methods if get_method(m).online)).agent_config(base_config(cfg)).online
    md = [f"### Online fine-tuning ({task})", "",
          f"Successes over the cell's evaluation episodes (the offline cell's episodes) versus environment steps "
          f"collected; {oc.num_envs} episodes per round, {oc.updates_per_env_step:g} world-model gradient step(s) per "
          f"environment step, online fraction {oc.mix_start:g} + {oc.mix_increment:g} every {oc.mix_every} steps up to "
          f"{oc.mix_max:g}. The last column is the world model's one-step error (normalised units) on each round's "
          f"new deployment transitions before training on them, first round → last round, and the frozen "
          f"offline model's error on the last round's data.", "",
          "| method, cell | env steps: successes/episodes | world-model error |", "|---|---|---|"]  # fmt: skip
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 3.5))
    for label, steps, rate, r_steps, err, err_off in lines:
        ax.plot(steps, rate, marker="o", label=label)
        (ln,) = ax2.plot(r_steps, err, marker=".", label=f"{label}: fine-tuned")
        ax2.plot(r_steps, err_off, linestyle="--", color=ln.get_color(), label=f"{label}: offline model")
    ax.set_xlabel("environment steps")
    ax.set_ylabel("success rate")
    ax.set_ylim(-0.05, 1.05)
    ax.set_title(f"{task}: online fine-tuning ({cfg.preset})")
    ax.legend(fontsize=7)
    ax2.set_xlabel("environment steps")
    ax2.set_ylabel("one-step error on new deployment data")
    ax2.set_yscale("log")
    ax2.legend(fontsize=7)
    _save_png(fig, out / f"{task}-online.png")
    return "\n".join(md + rows) + "\n"


def _save_png(fig, path: Path) -> None:
    """Save and close a figure atomically (temporary name, then rename)."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    tmp.replace(path)
