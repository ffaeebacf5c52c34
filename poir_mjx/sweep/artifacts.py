"""What a sweep makes and reuses: the expert data (and its content digest), trained agents
(checkpoints keyed on config and data), and cell records keyed on everything that shapes them."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import jax
import numpy as np

from poir_mjx.core import checkpoint
from poir_mjx.core.agent import POIR, POIRParams
from poir_mjx.core.config import ConfigError, POIRConfig, to_dict
from poir_mjx.data.robomimic import DatasetError, Transitions, read_transitions
from poir_mjx.envs.layout import obs_groups, observation_keys
from poir_mjx.eval.methods import Method, get_method
from poir_mjx.sweep.config import SweepConfig, base_config, baseline_config, config_dict, short_hash
from poir_mjx.sweep.records import read_cell  # noqa: F401  (the one reader of cell records; here for its callers)


def demos_for(cfg: SweepConfig, task: str, data_dir: Path, progress: bool = True) -> tuple[Transitions, dict]:
    """The expert transitions for `task` (the file made on first use; read once, ``tr.path`` names it)
    and their provenance, with a digest of their content ("sha256"), which keys checkpoints and cells. The observation
    read is the config's (``observation``: every low-dim key, or the object-state alone)."""
    keys = observation_keys(cfg.observation)
    if task in cfg.demo_files:
        tr = read_transitions(cfg.demo_files[task], task=task, obs_keys=keys)
        return tr, {"source": "file", "path": tr.path, "sha256": transitions_digest(tr)}
    from poir_mjx.data.demos import generate

    path = generate(task, cfg.num_demos, seed=0, sigma_init=0.02, out=data_dir, simulator=cfg.demo_simulator,
                    batch=cfg.demo_batch, progress=progress, style=cfg.demo_style)  # fmt: skip
    tr = read_transitions(path, task=task, obs_keys=keys)
    generator = tr.provenance.get("poir_mjx_generator", {})
    if not isinstance(generator, dict):
        raise DatasetError(f"{path}: field data.attrs['poir_mjx_generator'] is not a JSON object")
    return tr, {"source": "scripted expert", **generator, "sha256": transitions_digest(tr)}


def transitions_digest(tr: Transitions) -> str:
    """sha256 of the demos' names and (obs, actions, next_obs) as read for training: a replaced or
    corrupted file at the same path gives another digest, a byte-different copy of the same data not."""
    h = hashlib.sha256(json.dumps([tr.demo_names, list(tr.obs_keys)]).encode())
    for a in (tr.obs, tr.actions, tr.next_obs):
        h.update(np.ascontiguousarray(a, np.float32).tobytes())
    return h.hexdigest()[:16]


def content_digest(path: Path, task: str) -> str:
    """``transitions_digest`` of a robomimic file."""
    return transitions_digest(read_transitions(path, task=task))


def checkpoint_digest(path: Path) -> str:
    """sha256 of a checkpoint file's bytes (16 hex digits): which agent a cell ran. Its name only keys the training
    config and the data; an agent retrained from the same key on another machine or stack may differ."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]


def checkpoint_file(method: Method, cfg: SweepConfig, task: str, seed: int, provenance: dict,
                    ckpt_dir: Path) -> tuple[Path, POIRConfig, dict]:  # fmt: skip
    """Where the sweep keeps (method's kind, task, seed)'s agent trained on the data `provenance` describes
    (the path is keyed on the training config and the data), with the config and layout it must carry."""
    tcfg = method.training_config(base_config(cfg))
    layout = {"task": task, "obs_keys": list(observation_keys(cfg.observation)), "seed": seed, "demos": provenance}
    key = short_hash([config_dict(tcfg, online=False), layout])
    return Path(ckpt_dir) / task / f"{method.agent_kind}-seed{seed}-{key}.ckpt", tcfg, layout


def train_or_load(method: Method, cfg: SweepConfig, task: str, seed: int, tr: Transitions, provenance: dict,
                  ckpt_dir: Path, progress: bool = True):  # fmt: skip
    """The trained agent for (method's kind, task, seed), from its checkpoint if one matches."""
    from tqdm import tqdm

    path, tcfg, layout = checkpoint_file(method, cfg, task, seed, provenance, ckpt_dir)
    if path.exists():
        agent, params, _ = checkpoint.load(path, tcfg, layout)
    else:
        groups = obs_groups(task, observation=cfg.observation)
        if tr.obs.shape[1] != len(groups):
            raise DatasetError(f"{tr.path}: observations {list(observation_keys(cfg.observation))} are "
                               f"{tr.obs.shape[1]} wide, task {task} has {len(groups)}")  # fmt: skip
        agent = POIR(tcfg, tr.obs.shape[1], tr.actions.shape[1])
        raw_prior = method.agent_kind == "poir" and tcfg.bc_space == "raw"
        bc = _policy_heads(cfg, task, seed, provenance, ckpt_dir) if raw_prior else None
        bar = tqdm(total=tcfg.train.epochs * (2 if method.agent_kind == "poir" and bc is None else 1),
                   desc=f"train {task} {method.agent_kind} seed {seed}", unit="epoch", disable=not progress)  # fmt: skip

        def cb(name, epoch, loss):
            bar.update(1)
            bar.set_postfix({name: f"{float(np.mean(loss)):.4f}"})

        params, _ = agent.fit(jax.random.PRNGKey(seed), tr.obs, tr.actions, tr.next_obs, obs_groups=groups,
                              train_world_model=method.agent_kind == "poir", callback=cb, bc_params=bc)  # fmt: skip
        bar.close()
        checkpoint.save(path, agent, params, layout)
    return POIR(method.agent_config(base_config(cfg)), agent.obs_size, agent.act_size), params, path


def _policy_heads(cfg: SweepConfig, task: str, seed: int, provenance: dict, ckpt_dir: Path):
    """A raw-space POIR prior's BC heads from the policy agent's checkpoint (EBC's, same config, seed and data), if
    one is there: fitting them again would give them bit for bit (POIR.fit's bc_params); None otherwise."""
    path, tcfg, layout = checkpoint_file(get_method("EBC"), cfg, task, seed, provenance, ckpt_dir)
    return checkpoint.load(path, tcfg, layout)[1].bc if path.exists() else None


def cell_path(out: Path, task: str, method: str, si: float, sa: float, seed: int) -> Path:
    return out / "cells" / task / method / f"si={si:g}_sa={sa:g}_seed={seed}.json"


def method_config_dict(cfg: SweepConfig, method: str) -> dict:
    """What shapes a method's agent: its POIR config, or a baseline's own config."""
    m = get_method(method)
    if m.is_baseline:
        return {"baseline": method, **to_dict(baseline_config(cfg, method))}
    return config_dict(m.agent_config(base_config(cfg)), m.online)


def cell_hash(cfg: SweepConfig, task: str, method: str, demo_sha256: str) -> str:
    relevant = {
        "demo_sha256": demo_sha256,
        "preset": method_config_dict(cfg, method),
        "episodes": cfg.episodes,
        "max_steps": cfg.max_steps,
        "num_demos": cfg.num_demos,
        "demo_file": cfg.demo_files.get(task),
        **({"demo_simulator": cfg.demo_simulator} if cfg.demo_simulator != "robosuite" else {}),
        **({"demo_style": cfg.demo_style} if cfg.demo_style != "scripted" and task not in cfg.demo_files else {}),
        **({"simulator": cfg.simulator} if cfg.simulator != "mjx" else {}),
        "x64": cfg.x64,
        **({"observation": cfg.observation} if cfg.observation != "low_dim" else {}),
        **({"physics": cfg.physics} if cfg.physics != "reference" else {}),
    }
    return short_hash(relevant)


def load_run_agent(run_dir: str | Path, task: str, method: str, seed: int = 0,
                   data_dir: Path = Path("data/demos"), ckpt_dir: Path = Path("checkpoints"),
                   progress: bool = True) -> tuple[POIR, POIRParams, Method]:  # fmt: skip
    """The agent a sweep run evaluated for (task, method, seed): (agent set up for the method, params, Method).

    Reads ``<run_dir>/config.json``. The checkpoint is the one the sweep used: found under `ckpt_dir`
    from the data provenance the run's cells record (no demos read); if the run has no cell for it yet
    or the checkpoint is gone, the demos are read (made if missing) and the agent is trained, which is
    said on stderr. Online methods fine-tune per noise cell; their agents are not loaded here.
    """
    import sys

    from poir_mjx.sweep.config import load_sweep_config

    src = Path(run_dir) / "config.json"
    if not src.is_file():
        raise ConfigError(f"{src}: no such file; expected a sweep run folder (results/<name>/)")
    cfg = load_sweep_config(src, recorded=True)
    for field, value, allowed in (("tasks", task, cfg.tasks), ("methods", method, cfg.methods),
                                  ("seeds", seed, cfg.seeds)):  # fmt: skip
        if value not in allowed:
            raise ConfigError(f"{src}: field '{field}' has no {value!r} (the run has {list(allowed)})")
    m = get_method(method)
    if m.online or m.is_baseline:
        raise ConfigError(f"{src}: field 'methods': {method} trains a separate agent in each noise cell; "
                          "only offline methods can be loaded")  # fmt: skip
    prov = recorded_provenance(Path(run_dir), cfg, task, method, seed)
    if prov is not None:
        path, tcfg, layout = checkpoint_file(m, cfg, task, seed, prov, ckpt_dir)
        if path.exists():
            agent, params, _ = checkpoint.load(path, tcfg, layout)
            return POIR(m.agent_config(base_config(cfg)), agent.obs_size, agent.act_size), params, m
    tr, prov = demos_for(cfg, task, data_dir, progress)
    path, _, _ = checkpoint_file(m, cfg, task, seed, prov, ckpt_dir)
    if not path.exists():
        print(f"{path}: no checkpoint for run {cfg.name} ({task}, {method}, seed {seed}); training it now",
              file=sys.stderr)  # fmt: skip
    agent, params, _ = train_or_load(m, cfg, task, seed, tr, prov, ckpt_dir, progress)
    return agent, params, m


def recorded_provenance(out: Path, cfg: SweepConfig, task: str, method: str, seed: int) -> dict | None:
    """The expert-data provenance a cell of (task, method, seed) in run folder `out` was made with, if any
    cell made with `cfg` exists (its config hash checked)."""
    for si in cfg.sigma_init:
        for sa in cfg.sigma_action:
            path = cell_path(out, task, method, si, sa, seed)
            try:
                rec = json.loads(path.read_text())
            except (OSError, UnicodeDecodeError, ValueError):  # absent or unreadable: the sweep remakes it
                continue
            data = rec.get("data") if isinstance(rec, dict) else None
            if isinstance(data, dict) and rec.get("config_hash") == cell_hash(cfg, task, method,
                                                                              data.get("sha256", "")):
                return data
    return None
