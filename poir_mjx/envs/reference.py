"""robosuite's own MuJoCo simulation as the reference for MJX: shared initial states and rollouts."""

from __future__ import annotations

import dataclasses
import time

import mujoco
import numpy as np

from poir_mjx.envs.tasks import GRASP_SITE, grasp_offset, make_robosuite


def qpos_from_robosuite(rs_env, mj_model: mujoco.MjModel) -> np.ndarray:
    """The exported model's qpos holding robosuite's current joint values (matched by joint name)."""
    qpos = mj_model.qpos0.copy()
    rs_model = rs_env.sim.model._model
    for j in range(mj_model.njnt):
        name = mujoco.mj_id2name(mj_model, mujoco.mjtObj.mjOBJ_JOINT, j)
        rj = mujoco.mj_name2id(rs_model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if rj < 0:
            raise KeyError(f"joint {name} of the exported model is not in robosuite's model")
        n = {0: 7, 1: 4}.get(int(mj_model.jnt_type[j]), 1)
        a, ra = mj_model.jnt_qposadr[j], rs_model.jnt_qposadr[rj]
        qpos[a : a + n] = rs_env.sim.data.qpos[ra : ra + n]
    return qpos


def grasp_and_lift_action(step: int, eef_pos: np.ndarray, target: np.ndarray, yaw_error: float = 0.0) -> np.ndarray:
    """A fixed 90-step script: above the grasp point, down, close the gripper, lift 20 cm.

    Proportional in position (saturating at robosuite's 5 cm per step); before closing, the
    gripper turns about the vertical by half of `yaw_error` per step (0.5 rad per unit action).
    """
    if step < 25:
        goal, grip = target + np.array([0.0, 0.0, 0.10]), -1.0
    elif step < 45:
        goal, grip = target + np.array([0.0, 0.0, -0.005]), -1.0
    elif step < 60:
        goal, grip = target + np.array([0.0, 0.0, -0.005]), 1.0
    else:
        goal, grip = target + np.array([0.0, 0.0, 0.20]), 1.0
    a = np.zeros(7)
    a[:3] = np.clip(10.0 * (goal - eef_pos), -1.0, 1.0)
    a[5] = np.clip(yaw_error, -1.0, 1.0) if step < 45 else 0.0
    a[6] = grip
    return a


GRASP_SCRIPT_STEPS = 90
# Tasks whose grasp needs the fingers to close across the object's local y axis (the nut's handle).
ALIGN_TO_OBJECT_Y = ("nut_assembly_square",)


def _yaw_error(sim, obj_body: int) -> float:
    """Signed angle (about world z) from the fingers' closing axis to the object's local y axis, in [-pi/2, pi/2]."""
    f = sim.data.body_xpos[sim.model.body_name2id("gripper0_right_leftfinger")] - sim.data.body_xpos[
        sim.model.body_name2id("gripper0_right_rightfinger")
    ]
    n = sim.data.body_xmat[obj_body].reshape(3, 3)[:, 1]
    e = np.arctan2(f[0] * n[1] - f[1] * n[0], f[0] * n[0] + f[1] * n[1])
    return float((e + np.pi / 2) % np.pi - np.pi / 2)


@dataclasses.dataclass
class ReferenceRollout:
    qpos0: np.ndarray  # initial state in the exported model's layout
    actions: np.ndarray  # (T, 7)
    eef_pos: np.ndarray  # (T, 3) after each step
    obj_pos: np.ndarray  # (T, 3) after each step
    success: np.ndarray  # (T,) robosuite's _check_success after each step
    object_obs: np.ndarray  # (T + 1, object size): robosuite's object-state, reset then each step
    step_seconds: float  # mean wall time of robosuite's env.step


def robosuite_grasp_rollout(task: str, mj_model: mujoco.MjModel, seed: int = 0, steps: int = GRASP_SCRIPT_STEPS):
    """Run the grasp-and-lift script in robosuite (closed loop on its observations) and record it."""
    env = make_robosuite(task, seed=seed)
    obs = env.reset()
    qpos0 = qpos_from_robosuite(env, mj_model)
    site = env.sim.model.site_name2id(GRASP_SITE[task])
    offset = grasp_offset(task, mj_model)  # clear of the nut's wall
    acts, eef, objp, succ, objobs = [], [], [], [], [obs["object-state"].copy()]
    obj_body = int(env.sim.model.site_bodyid[site])
    t0 = time.perf_counter()
    for t in range(steps):
        if t < 45:  # track the grasp point until the gripper closes (objects settle after reset)
            r_obj = env.sim.data.body_xmat[obj_body].reshape(3, 3)
            target = env.sim.data.body_xpos[obj_body] + r_obj @ np.asarray(offset)
        yaw = _yaw_error(env.sim, obj_body) if task in ALIGN_TO_OBJECT_Y else 0.0
        a = grasp_and_lift_action(t, obs["robot0_eef_pos"], target, yaw)
        obs, _, _, _ = env.step(a)
        acts.append(a)
        eef.append(obs["robot0_eef_pos"].copy())
        objp.append(env.sim.data.body_xpos[obj_body].copy())
        succ.append(bool(env._check_success()))
        objobs.append(obs["object-state"].copy())
    dt = (time.perf_counter() - t0) / steps
    env.close()
    return ReferenceRollout(
        qpos0=qpos0,
        actions=np.array(acts),
        eef_pos=np.array(eef),
        obj_pos=np.array(objp),
        success=np.array(succ),
        object_obs=np.array(objobs),
        step_seconds=dt,
    )
