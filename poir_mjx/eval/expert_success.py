"""The scripted expert's success rate, in MJX (one compiled rollout over a batch of episodes) or in robosuite."""

from __future__ import annotations

import time

import jax
import numpy as np

from poir_mjx.data import mjx_demos
from poir_mjx.data.expert_episodes import EXPERT_STEPS, robosuite_episode
from poir_mjx.envs.env import make_params
from poir_mjx.envs.tasks import make_robosuite


def mjx_success(task: str, episodes: int, seed: int, sigma_init: float, steps: int | None = None) -> dict:
    """The expert in MJX: one compiled rollout (lax.scan over steps, vmap over episodes), the one the MJX
    demos use (compiled once per task, steps and batch)."""
    steps = steps or EXPERT_STEPS[task]
    params = make_params(np.full(episodes, sigma_init), 0.0)
    keys = jax.random.split(jax.random.PRNGKey(seed), episodes)
    t0 = time.perf_counter()
    res, _ = mjx_demos.expert_rollout(task, steps)(None, keys, params)
    first, diverged = np.asarray(res["first_success"]), np.asarray(res["diverged"])
    ok = first >= 0
    return {
        "simulator": "MJX",
        "episodes": episodes,
        "successes": int(ok.sum()),
        "diverged": int(diverged.sum()),
        "length_mean": float(first[ok].mean()) if ok.any() else None,
        "seconds": time.perf_counter() - t0,
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
