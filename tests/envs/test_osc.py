"""robosuite's OSC_POSE in JAX (poir_mjx/envs/osc.py) against values computed by hand."""

import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx.envs import osc


def rz(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def ry(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def test_scale_action_clips_then_maps_the_input_range_onto_the_output_range():
    lo, hi = -jnp.ones(6), jnp.ones(6)
    out_hi = jnp.array([0.05, 0.05, 0.05, 0.5, 0.5, 0.5])  # robosuite's OSC_POSE output limits
    a = jnp.array([0.5, -2.0, 1.0, 0.0, 0.2, -0.2])
    np.testing.assert_allclose(osc.scale_action(a, lo, hi, -out_hi, out_hi), [0.025, -0.05, 0.05, 0.0, 0.1, -0.1],
                               rtol=1e-6)  # fmt: skip
    # asymmetric ranges: [0, 2] -> [10, 20]; 1.5 -> 17.5, 3 clips to 2 -> 20
    np.testing.assert_allclose(osc.scale_action(jnp.array([1.5, 3.0]), 0.0, 2.0, 10.0, 20.0), [17.5, 20.0])


def test_orientation_error_of_a_rotation_about_z():
    # desired Rz(t), current I: 0.5 * (e1 x Rz e1 + e2 x Rz e2 + e3 x e3) = (0, 0, sin t)
    err = osc.orientation_error(jnp.asarray(rz(0.3)), jnp.eye(3))
    np.testing.assert_allclose(err, [0.0, 0.0, np.sin(0.3)], atol=1e-7)
    back = osc.orientation_error(jnp.eye(3), jnp.asarray(rz(0.3)))
    np.testing.assert_allclose(back, [0.0, 0.0, -np.sin(0.3)], atol=1e-7)


def test_goal_from_delta_reads_the_delta_in_the_base_frame():
    base = jnp.asarray(rz(np.pi / 2))  # the robot base turned 90 degrees about z
    ref_pos, ref_ori = jnp.array([0.1, 0.2, 0.3]), jnp.asarray(rz(0.2))
    delta = jnp.array([0.01, 0.0, 0.0, 0.4, 0.0, 0.0])  # +x and a turn about x, both in the base frame
    pos, ori = osc.goal_from_delta(delta, ref_pos, ref_ori, base)
    np.testing.assert_allclose(pos, [0.1, 0.21, 0.3], atol=1e-7)  # base x is world y
    np.testing.assert_allclose(ori, ry(0.4) @ rz(0.2), atol=1e-6)  # base x-axis turn is a world y-axis turn


def _arm(n=6, mass=1.0):
    jac_pos = np.zeros((3, n))
    jac_ori = np.zeros((3, n))
    jac_pos[:, :3], jac_ori[:, 3:6] = np.eye(3), np.eye(3)
    return dict(jac_pos=jnp.asarray(jac_pos), jac_ori=jnp.asarray(jac_ori), mass_matrix=mass * jnp.eye(n))


def test_osc_torques_with_decoupled_joints():
    """Joints 0-2 move the hand along x, y, z, joints 3-5 turn it: the task-space inertias are the mass."""
    kp = jnp.full(6, 150.0)
    kd = 2 * jnp.sqrt(kp)
    qvel = jnp.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.2])
    bias = jnp.arange(1.0, 7.0)
    tau = osc.osc_torques(goal_pos=jnp.array([0.01, 0.0, 0.0]), goal_ori=jnp.asarray(rz(0.3)), ref_pos=jnp.zeros(3),
                          ref_ori=jnp.eye(3), qvel=qvel, qpos=jnp.zeros(6), bias=bias, initial_joint=jnp.zeros(6),
                          kp=kp, kd=kd, nullspace_kp=10.0, **_arm(mass=2.0))  # fmt: skip
    kd0 = 2 * np.sqrt(150.0)
    force = [150 * 0.01 - kd0 * 0.1, 0.0, 0.0]
    torque = [0.0, 0.0, 150 * np.sin(0.3) - kd0 * 0.2]
    np.testing.assert_allclose(tau, 2.0 * np.array(force + torque) + np.arange(1.0, 7.0), rtol=1e-5)


def test_null_space_pulls_only_the_redundant_joint_to_its_initial_position():
    """A seventh joint that does not move the hand: only the null-space posture term drives it."""
    init = jnp.zeros(7)
    q = init.at[6].set(0.1)
    qvel = jnp.zeros(7).at[6].set(0.5)
    tau = osc.osc_torques(goal_pos=jnp.zeros(3), goal_ori=jnp.eye(3), ref_pos=jnp.zeros(3), ref_ori=jnp.eye(3),
                          qvel=qvel, qpos=q, bias=jnp.zeros(7), initial_joint=init, kp=jnp.full(6, 150.0),
                          kd=jnp.full(6, 24.0), nullspace_kp=10.0, **_arm(n=7))  # fmt: skip
    expect = np.zeros(7)
    expect[6] = 10.0 * (0.0 - 0.1) - 2 * np.sqrt(10.0) * 0.5
    np.testing.assert_allclose(tau, expect, atol=1e-5)


@pytest.mark.parametrize("prev, action, expect", [
    ([0.0, 0.0], 0.7, [-0.2, 0.2]),  # closing moves the command by the speed, whatever the magnitude
    ([-0.9, 0.9], 1.0, [-1.0, 1.0]),  # clipped at fully closed
    ([-1.0, 1.0], -0.3, [-0.8, 0.8]),  # opening
    ([-0.4, 0.4], 0.0, [-0.4, 0.4]),  # zero holds
])  # fmt: skip
def test_gripper_command_steps_by_the_speed_towards_the_sign(prev, action, expect):
    np.testing.assert_allclose(osc.gripper_command(jnp.array(prev), jnp.asarray(action), 0.2), expect, atol=1e-7)
