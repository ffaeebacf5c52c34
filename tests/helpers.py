"""Test helpers that several test folders use (one module; test files do not import each other).

- the point mass: expert data (s' = s + a, the expert moves along +x and jitters in y, so its states lie in a
  band), POIR configs small enough to train on it in seconds, and the deployment environment with a known model
  mismatch (``PointMassEnv``: the env protocol, a constant drift ``drift_y`` on y every step the demonstrations
  never showed, the y action scaled by ``gain_y``, y ~ N(0, sigma_init) at reset; success: x >= 1 while
  |y| < 0.05);
- ``StepLearner``: a baseline learner whose progress is known in advance (the run loop, the sweep's cells);
- ``make_demo``: a random robomimic demo with Lift's observation sizes;
- ``x64``: jax_enable_x64 set inside a block, restored afterwards;
- ``replay`` / ``assert_fidelity``: robosuite's grasp-and-lift rollout replayed in MJX, held to the fidelity
  tolerances (tests/envs/test_fidelity_*.py, one file per task so the suite's two workers share them out;
  tests/envs/test_solver_patch.py).
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools

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


# ---- MJX against robosuite: the grasp-and-lift replay (tests/envs/test_fidelity_*.py, test_solver_patch.py) ---------

# In float32 MJX's contact solve launched Square's 16 g nut during this grasp, which robosuite and
# MJX in float64 both complete (envs/README.md, "Precision"): its replay runs in float64.
FLOAT64_FIDELITY = ("nut_assembly_square",)
# Tolerances (metres, max over the 90-step grasp-and-lift replay, every step). Before the fingers
# touch the object the two simulators agree to micrometres; contact on the simplified geometry
# (prism can, box palm, MJX's convex collision) then shifts the grasp by millimetres. Measured on the
# 2-core CPU (Lift and Can in float32, Square in float64), end effector / object: Lift 0.28 / 0.75 mm,
# Can 12.0 / 4.6 mm, Square 5.9 / 6.9 mm. The bounds leave margin and stay under the scale that
# decides a grasp (finger pad 16 mm, objects 3-8 cm); the object must also rise by more than 5 cm in
# both simulators and the success flag must agree at every step.
EEF_TOL = {"lift": 2e-3, "pick_place_can": 2e-2, "nut_assembly_square": 1e-2}
OBJ_TOL = {"lift": 5e-3, "pick_place_can": 1.5e-2, "nut_assembly_square": 1e-2}
# During the script's approach (steps 0-24, above the object) nothing touches anything.
PRE_CONTACT_STEPS, PRE_CONTACT_TOL = 25, 2e-3


@functools.lru_cache(maxsize=None)
def robosuite_rollout(task):
    """robosuite's grasp-and-lift rollout (seed 1), recorded once per task whatever MJX physics replays it."""
    from poir_mjx.envs.env import make_env
    from poir_mjx.envs.reference import robosuite_grasp_rollout

    return robosuite_grasp_rollout(task, make_env(task).mj_model, seed=1)


@functools.lru_cache(maxsize=None)
def replay(task, physics=None):
    """robosuite's rollout and the same actions replayed in MJX (lane 0) beside a random episode (lane 1; batch 2,
    the batch the other MJX tests compile), with MJX's `physics` (a poir_mjx.envs.physics.PhysicsConfig or preset
    name; None: the reference): (rollout, first obs, object obs, eef, object position, success, last state)."""
    from poir_mjx.compat import enable_x64

    with enable_x64() if task in FLOAT64_FIDELITY else contextlib.nullcontext():
        return _replay(task, physics)


def _replay(task, physics):
    from poir_mjx.envs.env import batched, make_env, make_params

    env = make_env(task, physics=physics)
    _, reset_to, step = batched(task, physics=physics)
    ref = robosuite_rollout(task)
    params = make_params([0.0, 0.3], [0.0, 0.1])
    rand_qpos = jax.jit(jax.vmap(env.sample_qpos))(jax.random.split(jax.random.PRNGKey(3), 2), params)
    qpos = jnp.stack([jnp.asarray(ref.qpos0, rand_qpos.dtype), rand_qpos[1]])
    state = reset_to(qpos, jax.random.split(jax.random.PRNGKey(4), 2), params)
    first_obs = jax.tree_util.tree_map(np.asarray, state.obs)
    eef, obj, succ, objobs = [], [], [], []
    for a in ref.actions:
        state = step(state, jnp.tile(jnp.asarray(a, rand_qpos.dtype), (2, 1)))
        objobs.append(np.asarray(state.obs["object"]))
        eef.append(np.asarray(state.obs["robot0_eef_pos"]))
        obj.append(np.asarray(state.data.xpos[:, env._idx["obj_body"]]))
        succ.append(np.asarray(state.success))
    return ref, first_obs, np.array(objobs), np.array(eef), np.array(obj), np.array(succ), state


def assert_fidelity(task, physics=None):
    """MJX's replay of robosuite's grasp-and-lift (lane 0) within the tolerances above, the object lifted in both,
    the success flags equal at every step."""
    ref, first_obs, objobs, eef, obj, succ, _ = replay(task, physics)
    # The same robomimic "object" vector as robosuite at reset and after the first step (no contact
    # yet; objects still settle after being dropped by the placement sampler: 0.25 mm seen on Can).
    np.testing.assert_allclose(first_obs["object"][0], ref.object_obs[0], atol=1e-5)
    np.testing.assert_allclose(objobs[0, 0], ref.object_obs[1], atol=1e-3)
    pre = np.abs(eef[:PRE_CONTACT_STEPS, 0] - ref.eef_pos[:PRE_CONTACT_STEPS]).max()
    assert pre < PRE_CONTACT_TOL, pre
    eef_err = np.abs(eef[:, 0] - ref.eef_pos).max()
    obj_err = np.abs(obj[:, 0] - ref.obj_pos).max()
    print(f"{task} ({physics or 'reference'} physics): max eef error {eef_err:.2e} m, max object error {obj_err:.2e} m")
    assert eef_err < EEF_TOL[task]
    assert obj_err < OBJ_TOL[task]
    # The script closes the gripper on the object and lifts it: it must actually rise in both.
    assert ref.obj_pos[-1, 2] - ref.obj_pos[0, 2] > 0.05
    assert obj[-1, 0, 2] - obj[0, 0, 2] > 0.05
    np.testing.assert_array_equal(succ[:, 0], ref.success)


# Few steps: on jax 0.11.2's CPU backend (the current dependency set) a PickPlaceCan control step
# takes about 15 s at batch 2 (0.4 s on jax 0.7.0), see README "Dependencies".
ROLLOUT_STEPS = 5


def assert_batch_rollout(task):
    """5 control steps of two float32 episodes (sigma_init 0.02 and 0.3) under random actions, no robosuite: finite
    observations of the right shapes, the arm moved, nothing diverged (Lift: two cube sizes, both on the table)."""
    from poir_mjx.envs.env import batched, make_env, make_params

    env = make_env(task)
    reset, _, step = batched(task)
    params = make_params([0.02, 0.3], [0.0, 0.1])
    state = reset(jax.random.split(jax.random.PRNGKey(0), 2), params)
    assert state.data.qpos.dtype == jnp.float32
    actions = jax.random.uniform(jax.random.PRNGKey(1), (ROLLOUT_STEPS, 2, 7), minval=-1, maxval=1)
    start = np.asarray(state.obs["robot0_eef_pos"])
    for a in actions:
        state = step(state, a)
    sizes = env.obs_sizes
    assert sizes["object"] == (10 if task == "lift" else 14)
    for k, v in state.obs.items():
        assert v.shape == (2, sizes[k]), k
        assert np.all(np.isfinite(np.asarray(v))), k
    assert state.info["step"].tolist() == [ROLLOUT_STEPS, ROLLOUT_STEPS]
    assert not np.any(np.asarray(state.info["diverged"]))
    assert np.all(np.linalg.norm(np.asarray(state.obs["robot0_eef_pos"]) - start, axis=-1) > 1e-3)  # the arm moved
    if task == "lift":  # robosuite redraws the cube's size at every reset; so does the MJX Lift
        v = np.asarray(state.info["variant"])
        half_z = np.asarray(env.variants.sizes)[v, 2]
        bottom = np.asarray(state.data.xpos[:, env._idx["obj_body"], 2]) - half_z
        assert v[0] != v[1] and half_z[0] != half_z[1]
        np.testing.assert_allclose(bottom, env.meta["success"]["table_height"], atol=2e-3)  # resting on the table


def task_tests(task, physics_presets):
    """The MJX tests every task has (tests/envs/test_<task>.py binds them to its own names): the fidelity replay
    under each of `physics_presets` (None: the reference) and the float32 batch rollout."""
    import pytest

    @pytest.mark.slow
    @pytest.mark.needs_robosuite
    @pytest.mark.parametrize("physics", physics_presets)
    def test_fidelity_against_robosuite(physics):
        assert_fidelity(task, physics)

    @pytest.mark.slow
    @pytest.mark.current_stack
    def test_float32_batch_rollout_is_finite_with_right_shapes():
        assert_batch_rollout(task)

    return test_fidelity_against_robosuite, test_float32_batch_rollout_is_finite_with_right_shapes
