"""Test helpers that several test folders use (one module; test files do not import each other).

- the point mass: expert data (s' = s + a, the expert moves along +x and jitters in y, so its states lie in a
  band), POIR configs small enough to train on it in seconds, and the deployment environment with a known model
  mismatch (``PointMassEnv``: the env protocol, a constant drift ``drift_y`` on y every step the demonstrations
  never showed, the y action scaled by ``gain_y``, y ~ N(0, sigma_init) at reset; success: x >= 1 while
  |y| < 0.05);
- ``StepLearner``: a baseline learner whose progress is known in advance (the run loop, the sweep's cells);
- ``make_demo``: a random robomimic demo with Lift's observation sizes;
- ``x64``: jax_enable_x64 set inside a block, restored afterwards.
"""

from __future__ import annotations

import contextlib
import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.core.config import MLPConfig, PlannerConfig, POIRConfig, TrainConfig
from poir_mjx.data.robomimic import Demo
from poir_mjx.envs.env import State

# ---- the point mass ----------------------------------------------------------------------------------------------

def expert_data(n_demos=40, steps=25, seed=0):
    rng = np.random.default_rng(seed)
    obs, act, nxt = [], [], []
    for _ in range(n_demos):
        s = np.array([0.0, rng.normal(0, 0.02)])
        for _ in range(steps):
            a = np.array([0.05, rng.normal(0, 0.02)])
            s2 = s + a
            obs.append(s), act.append(a), nxt.append(s2)
            s = s2
    return np.array(obs, np.float32), np.array(act, np.float32), np.array(nxt, np.float32)


def tiny_config(k=3, width=16, epochs=4, batch=64, n=12, horizon=2, sigma=0.3, top_k=3, reward="dril"):
    """A POIR config small enough to train on the point mass in seconds."""
    return POIRConfig(ensemble_size=k, bc=MLPConfig(layers=2, width=width), world_model=MLPConfig(layers=2, width=width),
                      train=TrainConfig(epochs=epochs, batch_size=batch, learning_rate=3e-3),
                      planner=PlannerConfig(num_trajectories=n, horizon=horizon, sigma=sigma, top_k=top_k, reward=reward))  # fmt: skip


SMALL = POIRConfig(
    ensemble_size=3,
    bc=MLPConfig(layers=2, width=32),
    world_model=MLPConfig(layers=2, width=32),
    train=TrainConfig(epochs=60, batch_size=64, learning_rate=3e-3),
    planner=PlannerConfig(num_trajectories=64, horizon=3, sigma=1.0, top_k=4, reward="l2"),
    bc_space="normalized",  # the paper's prior; tests/core/test_prior.py covers the others
)


@dataclasses.dataclass(frozen=True)
class PointMassEnv:
    drift_y: float = 0.02
    gain_y: float = 1.0
    horizon: int = 30

    def obs_vector(self, state: State) -> jax.Array:
        return state.obs["s"]

    def reset(self, rng, params) -> State:
        k_init, k_ep = jax.random.split(rng)
        s = jnp.array([0.0, 1.0]) * params.sigma_init * jax.random.normal(k_init, (2,))
        info = {"rng": k_ep, "step": jnp.zeros((), jnp.int32), "first_success": jnp.full((), -1, jnp.int32),
                "diverged": jnp.zeros((), bool), "sigma_action": jnp.asarray(params.sigma_action, s.dtype)}  # fmt: skip
        return State(data=s, obs={"s": s}, done=jnp.zeros((), bool), success=jnp.zeros((), bool), info=info)

    def step(self, state: State, action) -> State:
        rng, k = jax.random.split(state.info["rng"])
        a = jnp.clip(action, -1, 1).astype(state.data.dtype) + state.info["sigma_action"] * jax.random.normal(k, (2,))
        s = state.data + jnp.array([1.0, self.gain_y]) * a + jnp.array([0.0, self.drift_y])
        step = state.info["step"] + 1
        success = (s[0] >= 1.0) & (jnp.abs(s[1]) < 0.05)
        first = jnp.where((state.info["first_success"] < 0) & success, step, state.info["first_success"])
        new = State(data=s, obs={"s": s}, done=step >= self.horizon, success=success,
                    info=dict(state.info, rng=rng, step=step, first_success=first))  # fmt: skip
        return jax.tree_util.tree_map(lambda old, nw: jnp.where(state.done, old, nw), state, new)


# ---- a learner with known progress -------------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class StepLearner:
    """Its policy moves x by `speed` a step; every iteration adds 0.01 to the speed (a 30-step episode succeeds
    once speed >= 1/30)."""

    num_envs: int = 4
    name: str = "step-learner"
    env_steps_per_iteration: int = 4

    def init(self, key, expert, env_params):
        return {"speed": jnp.float32(0.0), "env_steps": jnp.int32(0), "key": key}

    def train(self, state, iterations):
        return jax.jit(lambda s: ({**s, "speed": s["speed"] + 0.01 * iterations,
                                   "env_steps": s["env_steps"] + self.num_envs * iterations},
                                  {"imitation_reward": jnp.full(iterations, s["speed"])}))(state)  # fmt: skip

    def env_steps(self, state):
        return state["env_steps"]

    def policy_params(self, state):
        return state["speed"]

    def policy_fn(self):
        return lambda speed, obs, key: jnp.array([speed, -obs[1]])


# ---- robomimic demos ---------------------------------------------------------------------------------------------

ENV_ARGS = {"env_name": "Lift", "type": 1, "env_kwargs": {"control_freq": 20}}
SIZES = {"robot0_eef_pos": 3, "robot0_eef_quat": 4, "robot0_gripper_qpos": 2, "object": 10}


def make_demo(t, seed):
    rng = np.random.default_rng(seed)
    obs = {k: rng.normal(size=(t, d)) for k, d in SIZES.items()}
    nxt = {k: rng.normal(size=(t, d)) for k, d in SIZES.items()}
    return Demo(obs=obs, next_obs=nxt, actions=rng.uniform(-1, 1, (t, 7)), rewards=np.zeros(t),
                dones=np.r_[np.zeros(t - 1), 1], states=rng.normal(size=(t, 33)), model_file="<mujoco/>")


@contextlib.contextmanager
def x64(enabled: bool):
    """jax_enable_x64 set to `enabled` inside the block, restored afterwards."""
    prev = jax.config.jax_enable_x64
    jax.config.update("jax_enable_x64", enabled)
    try:
        yield
    finally:
        jax.config.update("jax_enable_x64", prev)


# ---- a project folder to probe (tests/test_hostile_inputs.py, tests/test_outputs.py) -------------------------------

PUBLISHED = "pub"  # the published run's name in `project`


def project(root, cells: dict | None = None):
    """A project folder under `root` (a git work tree) with a published run ``results/pub`` (config.json tracked by
    git, a table, a cell record), and results/, checkpoints/ and data/ holding a file each; returns the root."""
    import json
    import subprocess
    from pathlib import Path

    root = Path(root)
    run = root / "results" / PUBLISHED
    cell = run / "cells" / "lift" / "EBC" / "si=0.02_sa=0_seed=0.json"
    cell.parent.mkdir(parents=True)
    (run / "config.json").write_text(json.dumps({"name": PUBLISHED, "tasks": ["lift"], "methods": ["EBC"]}))
    (run / "lift.md").write_text("| method | σ_init 0.02 |\n")
    cell.write_text(json.dumps(cells or {"config_hash": "x", "episodes": 10, "successes": 4, "diverged": 0}))
    for folder in ("checkpoints/lift", "data/demos"):
        (root / folder).mkdir(parents=True)
        (root / folder / "keep.bin").write_bytes(b"\0\1\2")
    subprocess.run(["git", "init", "-q"], cwd=root, check=True)
    subprocess.run(["git", "add", str(run / "config.json")], cwd=root, check=True)
    return root


def snapshot(root) -> dict:
    """sha256 (or the link's target, or the kind) of every entry under results/, checkpoints/ and data/ of `root`."""
    import hashlib
    import os
    import stat
    from pathlib import Path

    out = {}
    for top in ("results", "checkpoints", "data"):
        for here, dirs, files in os.walk(Path(root) / top):
            for name in dirs + files:
                p = Path(here) / name
                st = os.lstat(p)
                if stat.S_ISLNK(st.st_mode):
                    out[str(p)] = "link " + os.readlink(p)
                elif stat.S_ISREG(st.st_mode):
                    out[str(p)] = hashlib.sha256(p.read_bytes()).hexdigest()
                else:
                    out[str(p)] = stat.S_IFMT(st.st_mode)
    return out


def one_line_error(capsys) -> str:
    """The command's error, asserted to be one line starting 'error: ', the last on stderr (a sweep says what runs
    first, on one line of its own) with no traceback; returned without the prefix."""
    err = capsys.readouterr().err
    lines = err.rstrip("\n").split("\n")
    assert err.endswith("\n") and "Traceback" not in err and len(lines) <= 2, err
    assert lines[-1].startswith("error: ") and not any(ln.startswith("error: ") for ln in lines[:-1]), err
    assert len(lines) == 1 or lines[0].startswith("sweep "), err
    return lines[-1][len("error: "):]
