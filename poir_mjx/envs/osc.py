"""robosuite's OSC_POSE controller (delta, base frame, fixed impedance) written in JAX.

Mirrors ``robosuite.controllers.parts.arm.osc.OperationalSpaceController`` with
``uncouple_pos_ori=True`` and no interpolator, the settings of robosuite's BASIC Panda config:
the goal is set once per policy step from the current end-effector pose; torques are
recomputed on every physics substep from the current state.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from poir_mjx.envs.rotation import axisangle_to_mat


def orientation_error(desired: jax.Array, current: jax.Array) -> jax.Array:
    """robosuite.utils.control_utils.orientation_error."""
    return 0.5 * (
        jnp.cross(current[:, 0], desired[:, 0])
        + jnp.cross(current[:, 1], desired[:, 1])
        + jnp.cross(current[:, 2], desired[:, 2])
    )


def scale_action(a, input_min, input_max, output_min, output_max):
    """Controller.scale_action: clip to the input range, map linearly to the output range."""
    scale = jnp.abs(output_max - output_min) / jnp.abs(input_max - input_min)
    out_mid = (output_max + output_min) / 2.0
    in_mid = (input_max + input_min) / 2.0
    return (jnp.clip(a, input_min, input_max) - in_mid) * scale + out_mid


def goal_from_delta(scaled_delta, ref_pos, ref_ori, origin_ori):
    """Goal pose in world coordinates for an 'achieved'-mode delta given in the base frame.

    robosuite keeps the goal in the base frame: goal_pos = R0^T (p - p0) + dp and
    goal_ori = R(dr) R0^T R; run_controller maps it back with p0 + R0 goal_pos and R0 goal_ori.
    """
    goal_pos = ref_pos + origin_ori @ scaled_delta[:3]
    goal_ori = origin_ori @ axisangle_to_mat(scaled_delta[3:6]) @ origin_ori.T @ ref_ori
    return goal_pos, goal_ori


def _pinv_spd(a: jax.Array) -> jax.Array:
    return jnp.linalg.pinv(a, hermitian=True)


def osc_torques(
    *,
    goal_pos,
    goal_ori,
    ref_pos,
    ref_ori,
    jac_pos,
    jac_ori,
    qvel,
    qpos,
    mass_matrix,
    bias,
    initial_joint,
    kp,
    kd,
    nullspace_kp,
):
    """Joint torques of robosuite's OSC (before clipping to the actuator range)."""
    vel_pos = jac_pos @ qvel
    vel_ori = jac_ori @ qvel
    desired_force = (goal_pos - ref_pos) * kp[:3] - vel_pos * kd[:3]
    desired_torque = orientation_error(goal_ori, ref_ori) * kp[3:] - vel_ori * kd[3:]

    m_inv = jnp.linalg.inv(mass_matrix)
    j_full = jnp.concatenate([jac_pos, jac_ori], 0)
    lambda_full = _pinv_spd(j_full @ m_inv @ j_full.T)
    lambda_pos = _pinv_spd(jac_pos @ m_inv @ jac_pos.T)
    lambda_ori = _pinv_spd(jac_ori @ m_inv @ jac_ori.T)
    wrench = jnp.concatenate([lambda_pos @ desired_force, lambda_ori @ desired_torque])
    torques = j_full.T @ wrench + bias

    jbar = m_inv @ j_full.T @ lambda_full
    nullspace = jnp.eye(qvel.shape[0]) - jbar @ j_full
    joint_kv = 2.0 * jnp.sqrt(nullspace_kp)
    pose_torques = mass_matrix @ (nullspace_kp * (initial_joint - qpos) - joint_kv * qvel)
    return torques + nullspace.T @ pose_torques


def gripper_command(prev_cmd, action, speed):
    """PandaGripper.format_action: the command moves by `speed` towards closed/open each policy step."""
    return jnp.clip(prev_cmd + jnp.array([-1.0, 1.0]) * speed * jnp.sign(action), -1.0, 1.0)
