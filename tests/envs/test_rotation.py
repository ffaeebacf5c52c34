"""Rotation helpers (poir_mjx/envs/rotation.py): hand-computed values, round trips, robosuite's sign convention."""

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.envs import rotation as rot

S = np.sqrt(0.5)
RZ90 = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def test_known_rotations():
    np.testing.assert_allclose(rot.axisangle_to_mat(jnp.array([0.0, 0.0, np.pi / 2])), RZ90, atol=1e-6)
    np.testing.assert_array_equal(rot.axisangle_to_mat(jnp.zeros(3)), np.eye(3))
    np.testing.assert_allclose(rot.mat_to_quat(jnp.asarray(RZ90)), [S, 0.0, 0.0, S], atol=1e-6)  # (w, x, y, z)
    np.testing.assert_allclose(rot.quat_xyzw_to_mat(jnp.array([0.0, 0.0, S, S])), RZ90, atol=1e-6)
    np.testing.assert_array_equal(rot.wxyz_to_xyzw(jnp.array([[1.0, 2.0, 3.0, 4.0]])), [[2.0, 3.0, 4.0, 1.0]])
    # Hamilton product: i * j = k; two 45-degree turns about z make 90 degrees
    np.testing.assert_array_equal(rot.quat_mul(jnp.array([0.0, 1, 0, 0]), jnp.array([0.0, 0, 1, 0])), [0.0, 0, 0, 1])
    c, s = np.cos(np.pi / 8), np.sin(np.pi / 8)
    np.testing.assert_allclose(rot.quat_mul(jnp.array([c, 0, 0, s]), jnp.array([c, 0, 0, s])), [S, 0, 0, S], atol=1e-6)


def test_matrix_quaternion_round_trip_on_every_branch_with_w_nonnegative():
    vecs = np.concatenate([
        np.random.default_rng(0).normal(size=(20, 3)),
        np.pi * np.eye(3) * 0.999,  # near half turns: the x, y and z branches of Shepperd's method
    ])  # fmt: skip
    for v in vecs:
        r = rot.axisangle_to_mat(jnp.asarray(v, jnp.float32))
        q = rot.mat_to_quat_xyzw(r)
        assert float(q[3]) >= 0.0, q  # robosuite's mat2quat returns w >= 0
        np.testing.assert_allclose(float(jnp.linalg.norm(q)), 1.0, atol=1e-6)
        np.testing.assert_allclose(rot.quat_xyzw_to_mat(q), r, atol=2e-5)
    q = rot.mat_to_quat_xyzw(jnp.asarray(np.diag([1.0, -1.0, -1.0])))  # a half turn about x: w = 0
    np.testing.assert_allclose(jnp.abs(q), [1.0, 0.0, 0.0, 0.0], atol=1e-6)
    jax.jit(rot.mat_to_quat_xyzw)(jnp.eye(3))  # branch-free: traceable
