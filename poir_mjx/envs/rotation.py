"""Rotations in JAX, robosuite's conventions: quaternions, rotation matrices, axis-angle vectors.

MuJoCo stores quaternions as (w, x, y, z); robosuite's observations (and so robomimic's data) give
them as (x, y, z, w). Every function says which order it takes and returns.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


def wxyz_to_xyzw(q_wxyz: jax.Array) -> jax.Array:
    """MuJoCo's (w, x, y, z) quaternion as robosuite's (x, y, z, w); batched or not."""
    return jnp.concatenate([q_wxyz[..., 1:], q_wxyz[..., :1]], -1)


def mat_to_quat(r: jax.Array) -> jax.Array:
    """Shepperd's method, branch-free: the unit quaternion (w, x, y, z) of a rotation matrix (either sign)."""
    t = jnp.trace(r)
    cands = jnp.stack(
        [
            jnp.array([1 + t, r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]),
            jnp.array([r[2, 1] - r[1, 2], 1 + 2 * r[0, 0] - t, r[0, 1] + r[1, 0], r[0, 2] + r[2, 0]]),
            jnp.array([r[0, 2] - r[2, 0], r[0, 1] + r[1, 0], 1 + 2 * r[1, 1] - t, r[1, 2] + r[2, 1]]),
            jnp.array([r[1, 0] - r[0, 1], r[0, 2] + r[2, 0], r[1, 2] + r[2, 1], 1 + 2 * r[2, 2] - t]),
        ]
    )
    k = jnp.argmax(jnp.array([t, r[0, 0], r[1, 1], r[2, 2]]))
    q = cands[k]
    return q / jnp.linalg.norm(q)


def mat_to_quat_xyzw(r: jax.Array) -> jax.Array:
    """robosuite's mat2quat: the unit quaternion with w >= 0, as (x, y, z, w)."""
    q = mat_to_quat(r)
    q = jnp.where(q[0] < 0, -q, q)
    return wxyz_to_xyzw(q)


def quat_xyzw_to_mat(q: jax.Array) -> jax.Array:
    """Rotation matrix of a unit quaternion given as (x, y, z, w)."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    return jnp.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def quat_mul(a: jax.Array, b: jax.Array) -> jax.Array:
    """Hamilton product a * b of (w, x, y, z) quaternions (rotation b, then a)."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return jnp.array(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


def axisangle_to_mat(v: jax.Array) -> jax.Array:
    """Rotation matrix of an axis-angle vector (robosuite's axisangle2quat -> quat2mat)."""
    angle = jnp.linalg.norm(v)
    safe = jnp.where(angle > 1e-12, angle, 1.0)
    k = v / safe
    kx = jnp.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    r = jnp.eye(3) + jnp.sin(angle) * kx + (1.0 - jnp.cos(angle)) * kx @ kx
    return jnp.where(angle > 1e-12, r, jnp.eye(3))
