"""``render_video``: a sweep cell's episodes re-run in MJX with the cell's keys and noise, drawn, encoded.

The agents are the run's own (``eval.artifacts.load_run_agent``), the episode keys the cell's
(``eval.evaluator.episode_keys`` over the run's grid, as the sweep splits them), so for a run
evaluated in MJX episode i is the sweep's episode i of that cell. A run evaluated in robosuite drew
its starting states in robosuite from seeds derived from the same keys: the video shows MJX's
episode for the key, not robosuite's. Side by side, both methods start from the same state (same
key, same cube size). Heavy imports (mujoco, the agents) happen on the first call.
"""

from __future__ import annotations

import contextlib
import math
import sys
from pathlib import Path
from typing import Iterator

import numpy as np

from poir_mjx.cached import builder
from poir_mjx.core.config import ConfigError
from poir_mjx.video.config import SOURCE, VideoConfig, check, default_out


def cell_episodes(run_cfg, src: Path, cfg: VideoConfig):
    """(keys [B], EnvParams [B]) of the requested episodes of the cell (sigma_init, sigma_action) of the run."""
    from poir_mjx.envs.env import make_params
    from poir_mjx.rollout.evaluator import episode_keys

    grid = [(si, sa) for si in run_cfg.sigma_init for sa in run_cfg.sigma_action]
    j = next((j for j, (si, sa) in enumerate(grid)
              if math.isclose(si, cfg.sigma_init, abs_tol=1e-9) and math.isclose(sa, cfg.sigma_action, abs_tol=1e-9)),
             None)  # fmt: skip
    if j is None:
        raise ConfigError(f"{src}: the run has no cell sigma_init {cfg.sigma_init:g}, sigma_action "
                          f"{cfg.sigma_action:g} (fields 'sigma_init' {list(run_cfg.sigma_init)}, "
                          f"'sigma_action' {list(run_cfg.sigma_action)})")  # fmt: skip
    n = run_cfg.episodes
    if max(cfg.episodes) >= n:
        raise ConfigError(f"{SOURCE}: field 'episodes': {max(cfg.episodes)} is not an episode of the cell "
                          f"(field 'episodes' of {src} is {n}: indices 0..{n - 1})")  # fmt: skip
    keys = episode_keys(cfg.seed, len(grid) * n)  # as the sweep splits them: one key per episode of the whole grid
    keys = keys[np.array([j * n + e for e in cfg.episodes])]
    si, sa = grid[j]
    return keys, make_params(np.full(len(cfg.episodes), si), np.full(len(cfg.episodes), sa))


@builder
def _recorder(task: str, method, agent, steps: int, x64: bool, observation: str):
    """One compiled recording rollout per (task, method, agent config, steps, precision, the run's observation)."""
    from poir_mjx.envs.env import make_env
    from poir_mjx.video.record import recorder

    return recorder(make_env(task, observation=observation), method.policy_fn(agent), steps)


def record(cfg: VideoConfig, run_cfg, keys, env_params, steps: int, progress: bool) -> list:
    """One ``Recording`` per method shown, all from `keys`."""
    from poir_mjx.compat import enable_x64
    from poir_mjx.sweep.artifacts import load_run_agent
    from poir_mjx.video.record import record_episodes

    recs = []
    for name in [cfg.method] + ([cfg.versus] if cfg.versus else []):
        agent, params, method = load_run_agent(cfg.run, cfg.task, name, cfg.seed, cfg.data, cfg.checkpoints, progress)
        if progress:
            print(f"video: {name}: {len(cfg.episodes)} episode(s) x {steps} steps in MJX (compiles first)",
                  file=sys.stderr)  # fmt: skip
        with enable_x64() if run_cfg.x64 else contextlib.nullcontext():
            run = _recorder(cfg.task, method, agent, steps, run_cfg.x64, run_cfg.observation)
            recs.append(record_episodes(run, params, keys, env_params))
    return recs


def frames(task: str, names: list[str], recs: list, episodes, si: float, width: int, height: int,
           camera: str) -> Iterator[np.ndarray]:  # fmt: skip
    """uint8 [H, W * len(names), 3] per step of each episode: the methods side by side, captioned."""
    from poir_mjx.video.render import Painter, caption, renderer
    from poir_mjx.video.scene import scene_model

    for b, ep in enumerate(episodes):
        variant = int(recs[0].variant[b])
        assert all(int(r.variant[b]) == variant for r in recs), "same key, same reset: same object size"
        model = scene_model(task, variant)
        with renderer(model, width, height) as r:
            painter = Painter(r, model, camera)
            for t in range(recs[0].qpos.shape[1]):
                tiles = []
                for name, rec in zip(names, recs):
                    first = int(rec.first_success[b])
                    lines = [name, f"sigma_init={si:g}, episode {ep}, step {t}"]
                    if 0 <= first <= t:
                        lines.append(f"success at step {first}")
                    elif bool(rec.diverged[b]) and t == rec.qpos.shape[1] - 1:
                        lines.append("physics diverged")
                    tiles.append(caption(painter.frame(rec.qpos[b, t]), lines))
                yield np.concatenate(tiles, axis=1)


def render_video(cfg: VideoConfig, progress: bool = True) -> Path:
    """Render `cfg`'s episodes to an MP4 (written atomically) and return its path."""
    from poir_mjx.sweep.config import load_sweep_config
    from poir_mjx.video.encode import write_mp4
    from poir_mjx.video.render import check_camera, check_gl

    check(cfg)
    check_gl()  # before minutes of compilation: a missing EGL/OSMesa is one line now
    check_camera(cfg.task, cfg.camera)
    src = Path(cfg.run) / "config.json"
    if not src.is_file():
        raise ConfigError(f"{src}: no such file; field 'run' must be a sweep run folder (results/<name>/)")
    run_cfg = load_sweep_config(src, recorded=True)
    keys, env_params = cell_episodes(run_cfg, src, cfg)
    steps = cfg.steps or run_cfg.max_steps
    recs = record(cfg, run_cfg, keys, env_params, steps, progress)
    names = [cfg.method] + ([cfg.versus] if cfg.versus else [])
    out = cfg.out if cfg.out is not None else default_out(cfg)
    write_mp4(out, frames(cfg.task, names, recs, cfg.episodes, cfg.sigma_init, cfg.width, cfg.height, cfg.camera),
              cfg.fps)  # fmt: skip
    if progress:
        for name, rec in zip(names, recs):
            ok = ", ".join(f"ep {e}: " + (f"success at step {s}" if s >= 0 else "no success")
                           for e, s in zip(cfg.episodes, rec.first_success))  # fmt: skip
            print(f"video: {name} in MJX: {ok}", file=sys.stderr)
    return out
