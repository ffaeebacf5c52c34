"""A stateless grasp-and-lift policy for Lift that reads only the policy's observation vector.

A pure (params, obs, key) -> action function, so both evaluators (MJX and robosuite) can run it
with no training: above the cube, down, close, lift. Observation layout: robomimic's low-dim keys
(eef pos 0:3, eef quat 3:7, finger joints 7:9, cube pos 9:12, cube quat 12:16, cube - eef 16:19).
"""

import jax.numpy as jnp


def scripted_lift(params, obs, key):
    d = obs[16:19]  # cube position relative to the gripper
    holding = ((obs[7] - obs[8]) < 0.05) & (jnp.linalg.norm(d) < 0.02)
    above = jnp.linalg.norm(d[:2]) < 0.01
    target = jnp.where(above, d + jnp.array([0.0, 0.0, -0.005]), d + jnp.array([0.0, 0.0, 0.06]))
    near = jnp.linalg.norm(d - jnp.array([0.0, 0.0, -0.005])) < 0.012
    move = jnp.where(holding, jnp.array([0.0, 0.0, 0.2]), target)
    a = jnp.zeros(7, jnp.float32).at[:3].set(jnp.clip(10.0 * move, -1.0, 1.0))
    return a.at[6].set(jnp.where(near | holding, 1.0, -1.0))
