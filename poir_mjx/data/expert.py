"""Scripted experts for Lift, PickPlaceCan and NutAssemblySquare, acting through OSC_POSE.

One pure JAX state machine per task, driven only by robomimic's low-dim observations (so the
same code runs on robosuite's observations and inside a vmapped MJX rollout). Phases:

    0 approach above the grasp point  1 descend  2 close  3 lift
    4 carry over the target           5 lower    6 open   7 retreat

Lift stops after phase 3. Variety: each episode draws its approach height, grasp depth, lift and
carry heights, release point, speed gain and closing time, and every position action gets small
Gaussian jitter, so the data covers a neighbourhood of the expert path. The rotation actions are a
fixed function of the observation; ``expert_human.py`` adds an operator's variability on top (the
``human_like`` demo style).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct

from poir_mjx.cached import builder
from poir_mjx.envs.rotation import quat_xyzw_to_mat
from poir_mjx.envs.tasks import grasp_offset

NAME = "poir-mjx scripted expert v1"
# How the expert acts: "scripted" (this module alone) or "human_like" (expert_human.py's operator variability).
STYLES = ("scripted", "human_like")


def generator_record(task: str, num: int, seed: int, sigma_init: float, simulator: str,
                     style: str = "scripted") -> dict:  # fmt: skip
    """What identifies a demo file made by this expert (stored in it; equal records mean equal settings). The
    style is named unless it is "scripted", so the records (and the checkpoint keys made from them) of files
    made before styles existed stay as they were."""
    rec = {"expert": NAME, "simulator": simulator, "task": task, "num_demos": num, "seed": seed,
           "sigma_init": sigma_init, "sigma_action": 0.0}  # fmt: skip
    return rec if style == "scripted" else {**rec, "demo_style": style}


@dataclasses.dataclass(frozen=True)
class ExpertTask:
    task: str
    obj_pos_slice: tuple[int, int]  # where the object's position sits in the "object" vector
    obj_quat_slice: tuple[int, int]  # its quaternion (x, y, z, w)
    finger_axis_hand: tuple[float, float, float]  # fingers' closing axis in the hand body's frame
    grasp_offset_obj: tuple[float, float, float]  # grasp point in the object's frame
    yaw_symmetry: float  # grasp yaw is defined modulo this (0: any yaw)
    grasp_dz: tuple[float, float]  # range of the grasp height relative to the grasp point
    release_jitter: float  # half-width of the random xy offset of the release point
    target_xy: tuple[float, float]  # where the object goes (Can: bin quadrant centre; Square: peg)
    carry_z: float  # object height while carrying
    release_obj_z: float  # object height at which the gripper opens
    table_z: float


@struct.dataclass
class ExpertState:
    phase: jax.Array
    timer: jax.Array
    rng: jax.Array
    approach_h: jax.Array
    grasp_dz: jax.Array
    lift_h: jax.Array
    gain: jax.Array
    close_steps: jax.Array
    target_jitter: jax.Array  # (2,) xy offset of the release point
    jitter: jax.Array  # std of the per-step action noise


def _wrap(angle, period):
    return (angle + period / 2) % period - period / 2


@builder
def expert_task(task: str, envs_dir: str | None = None) -> ExpertTask:
    """Task constants read from the exported model (finger axis, handle offset, targets)."""
    from poir_mjx.envs.model import load_model

    m, meta = load_model(task, envs_dir)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    hand = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, meta["controller"]["eef_body"])
    jnt = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, meta["controller"]["gripper_joints"][0])
    axis = d.xmat[hand].reshape(3, 3).T @ d.xaxis[jnt]  # the fingers slide along this axis
    axis = tuple(float(v) for v in axis / np.linalg.norm(axis))
    if task == "lift":
        return ExpertTask(task, (0, 3), (3, 7), axis, grasp_offset(task, m), np.pi / 2, (-0.012, -0.002), 0.0, (0.0, 0.0), 0.0, 0.0,
                          meta["success"]["table_height"])  # fmt: skip
    if task == "pick_place_can":
        s = meta["success"]
        cx, cy = (s["bin_low"][0] + s["bin_high"][0]) / 2, (s["bin_low"][1] + s["bin_high"][1]) / 2
        return ExpertTask(task, (7, 10), (10, 14), axis, grasp_offset(task, m), 0.0, (-0.015, 0.0), 0.015, (cx, cy), s["bin_high"][2] + 0.08,
                          s["bin_low"][2] + 0.075, s["bin_low"][2])  # fmt: skip
    peg = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, meta["success"]["peg_body"])
    peg_top = float(d.xpos[peg][2] + 0.1)
    return ExpertTask(task, (7, 10), (10, 14), axis, grasp_offset(task, m), np.pi, (-0.004, 0.002), 0.002,
                      (float(d.xpos[peg][0]), float(d.xpos[peg][1])), peg_top + 0.07,
                      meta["success"]["max_height"] - 0.03, meta["success"]["max_height"] - 0.05)  # fmt: skip


def init(task: ExpertTask, rng: jax.Array) -> ExpertState:
    """Draw one episode's style."""
    ks = jax.random.split(rng, 8)
    u = lambda k, lo, hi, shape=(): jax.random.uniform(k, shape, minval=lo, maxval=hi)  # noqa: E731
    return ExpertState(
        phase=jnp.zeros((), jnp.int32),
        timer=jnp.zeros((), jnp.int32),
        rng=ks[0],
        approach_h=u(ks[1], 0.06, 0.12),
        grasp_dz=u(ks[2], *task.grasp_dz),
        lift_h=u(ks[3], 0.12, 0.22),
        gain=u(ks[4], 0.5, 0.9),
        close_steps=jax.random.randint(ks[5], (), 10, 15),
        target_jitter=u(ks[6], -task.release_jitter, task.release_jitter, (2,)),
        jitter=u(ks[7], 0.02, 0.06),
    )


def object_pose(task: ExpertTask, obs: dict) -> tuple[jax.Array, jax.Array, jax.Array]:
    """The object's position, rotation matrix and grasp point, from the observation."""
    o = obs["object"]
    obj = o[task.obj_pos_slice[0] : task.obj_pos_slice[1]]
    r_obj = quat_xyzw_to_mat(o[task.obj_quat_slice[0] : task.obj_quat_slice[1]])
    return obj, r_obj, obj + r_obj @ jnp.asarray(task.grasp_offset_obj)


def act(task: ExpertTask, obs: dict, st: ExpertState) -> tuple[jax.Array, ExpertState]:
    """One expert action (7,) in [-1, 1] and the next expert state."""
    eef = obs["robot0_eef_pos"]
    r_hand = quat_xyzw_to_mat(obs["robot0_eef_quat"])
    obj, r_obj, grasp = object_pose(task, obs)
    held_offset = eef - obj  # eef relative to the object (meaningful once grasped)
    is_lift = task.task == "lift"

    # Orientation: fingers' closing axis across the object (modulo its symmetry), hand pointing down.
    finger = r_hand @ jnp.asarray(task.finger_axis_hand)
    f_yaw = jnp.arctan2(finger[1], finger[0])
    if task.task == "lift":
        want = jnp.arctan2(r_obj[1, 0], r_obj[0, 0])  # a cube face normal
    elif task.task == "nut_assembly_square":
        want = jnp.arctan2(r_obj[1, 1], r_obj[0, 1])  # across the handle (nut's y axis)
    else:
        want = f_yaw
    yaw_grasp = _wrap(want - f_yaw, task.yaw_symmetry) if task.yaw_symmetry else 0.0
    nut_yaw = jnp.arctan2(r_obj[1, 0], r_obj[0, 0])
    if task.task == "nut_assembly_square":
        # Square the nut with the peg, handle towards the robot or sideways (never away: out of reach).
        errs = _wrap(jnp.array([jnp.pi / 2, jnp.pi, -jnp.pi / 2]) - nut_yaw, 2 * jnp.pi)
        yaw_carry = errs[jnp.argmin(jnp.abs(errs))]
    else:
        yaw_carry = 0.0

    tgt = jnp.asarray(task.target_xy) + st.target_jitter
    above_grasp = grasp + jnp.array([0.0, 0.0, st.approach_h])
    at_grasp = grasp + jnp.array([0.0, 0.0, st.grasp_dz])
    lift_z = task.table_z + st.lift_h + (0.06 if is_lift else 0.0)
    carry_eef_z = jnp.maximum(task.carry_z + held_offset[2], lift_z)
    goals = jnp.stack(
        [
            above_grasp,
            at_grasp,
            at_grasp,
            jnp.array([eef[0], eef[1], jnp.where(is_lift, lift_z, carry_eef_z)]),
            jnp.concatenate([tgt + held_offset[:2], carry_eef_z[None]]),
            jnp.concatenate([tgt + held_offset[:2], (task.release_obj_z + held_offset[2])[None]]),
            eef,
            eef + jnp.array([0.0, 0.0, 0.1]),
        ]
    )
    p = st.phase
    goal = goals[p]
    grip = jnp.where((p >= 2) & (p <= 5), 1.0, -1.0)
    yaw_err = jnp.where(p <= 1, yaw_grasp, jnp.where((p >= 3) & (p <= 5), yaw_carry, 0.0))

    err = goal - eef
    dist_xy = jnp.linalg.norm(err[:2])
    t = st.timer
    advance = jnp.select(
        [p == 0, p == 1, p == 2, p == 3, p == 4, p == 5, p == 6],
        [
            ((dist_xy < 0.005) & (jnp.abs(err[2]) < 0.02) & (jnp.abs(yaw_grasp) < 0.06)) | (t > 80),
            ((dist_xy < 0.004) & (jnp.abs(err[2]) < 0.008)) | (t > 40),
            t >= st.close_steps,
            jnp.logical_not(is_lift) & ((jnp.abs(err[2]) < 0.02) | (t > 60)),
            (dist_xy < 0.003) & (jnp.abs(err[2]) < 0.03) & (jnp.abs(yaw_carry) < 0.05) | (t > 120),
            (jnp.abs(err[2]) < 0.01) | (t > 50),
            t >= 5,
        ],
        False,
    )

    rng, k = jax.random.split(st.rng)
    a_pos = jnp.clip(st.gain * err / 0.05 + st.jitter * jax.random.normal(k, (3,)), -1.0, 1.0)
    # Keep the hand pointing down (x/y rotation) and turn about z by the yaw error.
    tilt = jnp.cross(r_hand[:, 2], jnp.array([0.0, 0.0, -1.0]))  # turns the hand's z axis onto world -z
    a_rot = jnp.concatenate([jnp.clip(0.5 * tilt[:2] / 0.5, -0.3, 0.3), jnp.clip(jnp.atleast_1d(0.8 * yaw_err / 0.5), -1, 1)])
    action = jnp.concatenate([a_pos, a_rot, jnp.atleast_1d(grip)])
    nxt = st.replace(phase=jnp.where(advance, p + 1, p), timer=jnp.where(advance, 0, t + 1), rng=rng)
    return action, nxt
