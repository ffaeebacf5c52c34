"""robosuite's object placement at reset (its ``UniformRandomSampler``), in JAX."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from poir_mjx.envs.rotation import quat_mul


def sample_object_pose(rng: jax.Array, p: dict) -> tuple[jax.Array, jax.Array]:
    """(position, quaternion (w, x, y, z)) of the object, drawn as robosuite's sampler described by the
    task metadata's ``placement`` `p` draws it: uniform in the x/y ranges (kept inside by the object's
    radius when the sampler ensures its boundary), resting on the reference surface, rotated about
    the sampler's axis (uniform in the range, fixed, or any angle), then by the object's initial quaternion."""
    kx, ky, kr = jax.random.split(rng, 3)
    r = p["horizontal_radius"] if p["ensure_object_boundary_in_range"] else 0.0
    x = jax.random.uniform(kx, (), minval=p["x_range"][0] + r, maxval=p["x_range"][1] - r)
    y = jax.random.uniform(ky, (), minval=p["y_range"][0] + r, maxval=p["y_range"][1] - r)
    ref = p["reference_pos"]
    pos = jnp.array([x + ref[0], y + ref[1], p["z_offset"] + ref[2] - p["bottom_offset"][2]])
    rot = p["rotation"]
    if rot is None:
        angle = jax.random.uniform(kr, (), minval=0.0, maxval=2 * jnp.pi)
    elif len(rot) > 1:
        angle = jax.random.uniform(kr, (), minval=min(rot), maxval=max(rot))
    else:
        angle = jnp.asarray(rot[0])
    axis = {"x": 1, "y": 2, "z": 3}[p["rotation_axis"]]
    quat = jnp.zeros(4).at[0].set(jnp.cos(angle / 2)).at[axis].set(jnp.sin(angle / 2))
    return pos, quat_mul(quat, jnp.asarray(p["init_quat"]))
