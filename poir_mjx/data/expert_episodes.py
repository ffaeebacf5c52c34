"""Scripted-expert episodes in robosuite (MuJoCo C) and in MJX, recorded in robomimic's layout."""

from __future__ import annotations

import time

import jax
import numpy as np

from poir_mjx.cached import builder
from poir_mjx.data import expert as ex
from poir_mjx.data.expert_human import expert_fns, expert_steps
from poir_mjx.data.robomimic import LOW_DIM_KEYS, Demo, robosuite_obs
from poir_mjx.envs.tasks import HORIZON, make_robosuite

EXPERT_STEPS = {"lift": 120, "pick_place_can": 300, "nut_assembly_square": 300}


def episode_steps(task: str, style: str = "scripted") -> int:
    """Steps an expert episode of `style` is given (the human-like expert's pauses and re-grasps take longer)."""
    return expert_steps(EXPERT_STEPS[task], style, HORIZON)


@builder
def _jit_expert(task: str, style: str = "scripted"):
    init, act = expert_fns(ex.expert_task(task), style)
    return jax.jit(init), jax.jit(act)


def robosuite_episode(task: str, seed: int, sigma_init: float = 0.02, max_steps: int | None = None, env=None,
                      style: str = "scripted"):  # fmt: skip
    """One expert episode in robosuite. Returns (Demo, success, steps, seconds). Stops 5 steps after success."""
    env = env or make_robosuite(task, seed=seed, initialization_noise={"magnitude": sigma_init, "type": "gaussian"})
    init, act = _jit_expert(task, style)
    raw = env.reset()
    st = init(jax.random.PRNGKey(seed))
    obs_l, nxt_l, acts, states, rewards, dones = [], [], [], [], [], []
    t0, success, after = time.perf_counter(), False, 0
    for t in range(max_steps or min(episode_steps(task, style), HORIZON)):
        o = robosuite_obs(raw)
        a, st = act(o, st)
        a = np.asarray(a, np.float64)
        states.append(np.asarray(env.sim.get_state().flatten()))
        raw, r, _, _ = env.step(a)
        success = success or bool(env._check_success())
        obs_l.append(o), nxt_l.append(robosuite_obs(raw)), acts.append(a), rewards.append(float(env._check_success()))
        dones.append(0)
        after += int(success)
        if after >= 5:
            break
    dones[-1] = 1
    stack = lambda lst: {k: np.stack([x[k] for x in lst]) for k in LOW_DIM_KEYS}  # noqa: E731
    demo = Demo(obs=stack(obs_l), next_obs=stack(nxt_l), actions=np.array(acts), rewards=np.array(rewards),
                dones=np.array(dones), states=np.array(states), model_file=None)  # fmt: skip
    return demo, success, len(acts), time.perf_counter() - t0
