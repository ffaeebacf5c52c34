"""The scripted expert's success rate, in MJX (one compiled rollout over a batch of episodes) or in robosuite."""

from __future__ import annotations

import json
import time
from pathlib import Path

import jax
import numpy as np

from poir_mjx.atomic import atomic_write_text
from poir_mjx.compat import x64_enabled
from poir_mjx.core.config import ConfigError
from poir_mjx.data import mjx_demos
from poir_mjx.data.expert_episodes import EXPERT_STEPS, robosuite_episode
from poir_mjx.envs.env import make_params
from poir_mjx.envs.tasks import make_robosuite


def mjx_partial_path(folder: Path, task: str, episodes: int, seed: int, sigma_init: float, steps: int,
                     x64: bool = False, physics: str = "reference") -> Path:  # fmt: skip
    """Where ``mjx_success`` keeps the outcomes of its finished batches: one file per measurement, precision and
    physics preset."""
    tag = f"{'-f64' if x64 else ''}{'' if physics == 'reference' else '-' + physics}"
    name = f"success-{task}-mjx-n{episodes}-seed{seed}-si{sigma_init:g}-T{steps}{tag}.json"
    return Path(folder) / name


def _read_partial(path: Path | None, ident: dict) -> dict:
    """The finished batches' outcomes in `path` (empty if none); ConfigError naming the field if it is not this
    measurement's record."""
    empty = {**ident, "first_success": [], "diverged": [], "seconds": 0.0}
    if path is None or not path.exists():
        return empty
    try:
        done = json.loads(path.read_text())
    except ValueError as e:
        raise ConfigError(f"{path}: not JSON ({e}); delete it to start the measurement over") from None
    for field in (*ident, "first_success", "diverged", "seconds"):
        want = ident.get(field, empty[field])
        if not isinstance(done, dict) or field not in done or type(done[field]) is not type(want) or (
                field in ident and done[field] != want):  # fmt: skip
            raise ConfigError(f"{path}: field '{field}' does not match this measurement ({want!r}); delete it to start over")
    if len(done["first_success"]) != len(done["diverged"]) or len(done["diverged"]) > ident["episodes"]:
        raise ConfigError(f"{path}: field 'first_success' and 'diverged' hold different or too many episodes")
    return done


def mjx_success(task: str, episodes: int, seed: int, sigma_init: float, steps: int | None = None, batch: int = 0,
                partial: Path | None = None, progress: bool = False, physics: str = "reference") -> dict:  # fmt: skip
    """The expert in MJX: compiled rollouts (lax.scan over steps, vmap over episodes), the one the MJX demos use.

    Episode i's key is ``split(PRNGKey(seed), episodes)[i]`` however the episodes are batched. ``batch`` > 0 runs
    them `batch` at a time (physics: a preset of ``envs.physics``) (one compiled shape; the last batch is padded with copies of its last key, dropped);
    0 runs all at once. With `partial` (a file path), every finished batch's outcomes are written there
    atomically, and a rerun of the same measurement resumes after them; "seconds" sums the runs' batches.
    """
    steps = steps or EXPERT_STEPS[task]
    batch = episodes if batch <= 0 else min(batch, episodes)
    ident = {"task": task, "episodes": episodes, "seed": seed, "sigma_init": sigma_init, "steps": steps,
             "x64": x64_enabled(),  # a float32 run's batches are not resumed in float64, nor the reverse
             **({"physics": physics} if physics != "reference" else {})}  # fmt: skip
    done = _read_partial(partial, ident)
    keys = jax.random.split(jax.random.PRNGKey(seed), episodes)
    params = make_params(np.full(batch, sigma_init), 0.0)
    rollout = mjx_demos.expert_rollout(task, steps, physics=physics)
    from tqdm import tqdm

    bar = tqdm(total=episodes, initial=len(done["first_success"]), desc=f"expert {task} (MJX, batch {batch})",
               unit="episode", disable=not progress)  # fmt: skip
    while len(done["first_success"]) < episodes:
        start = len(done["first_success"])
        idx = np.minimum(np.arange(start, start + batch), episodes - 1)
        t0 = time.perf_counter()
        res, _ = rollout(None, keys[idx], params)
        real = min(batch, episodes - start)
        done["first_success"] += [int(x) for x in np.asarray(res["first_success"])[:real]]
        done["diverged"] += [bool(x) for x in np.asarray(res["diverged"])[:real]]
        done["seconds"] += time.perf_counter() - t0
        if partial is not None:
            atomic_write_text(partial, json.dumps(done) + "\n")
        bar.update(real)
    bar.close()
    first, diverged = np.array(done["first_success"]), np.array(done["diverged"], bool)
    ok = first >= 0
    return {
        "simulator": "MJX" if physics == "reference" else f"MJX ({physics} physics)",
        "episodes": episodes,
        "successes": int(ok.sum()),
        "diverged": int(diverged.sum()),
        "length_mean": float(first[ok].mean()) if ok.any() else None,
        "seconds": done["seconds"],
        # per episode, in key order: the step of first success (-1: none) and divergence, so that two physics
        # settings' runs of the same episodes can be compared episode by episode
        "first_success": [int(x) for x in first],
        "diverged_episodes": [int(i) for i in np.flatnonzero(diverged)],
    }


def robosuite_success(task: str, episodes: int, seed: int, sigma_init: float) -> dict:
    env = make_robosuite(task, seed=seed, initialization_noise={"magnitude": sigma_init, "type": "gaussian"})
    t0, res = time.perf_counter(), []
    for k in range(episodes):
        _, ok, steps, _ = robosuite_episode(task, seed * 100003 + k, sigma_init, env=env)
        res.append((ok, steps))
    ok = np.array([r[0] for r in res])
    lengths = np.array([r[1] for r in res])
    return {
        "simulator": "robosuite (MuJoCo C)",
        "episodes": episodes,
        "successes": int(ok.sum()),
        "diverged": 0,
        "length_mean": float(lengths[ok].mean()) if ok.any() else None,
        "seconds": time.perf_counter() - t0,
    }
