"""What a task reads from the MJX state: robomimic's low-dim observation and robosuite's success check.

`idx` is the model's index table (``model.model_indices``), `meta` the task's exported metadata.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from mujoco import mjx

from poir_mjx.envs.layout import OBS_KEYS
from poir_mjx.envs.model import ModelFileError
from poir_mjx.envs.rotation import mat_to_quat_xyzw, wxyz_to_xyzw


def observe(idx: dict, meta: dict, d: mjx.Data, prev_obj_pos=None, prev_obj_mat=None) -> dict[str, jax.Array]:
    """robomimic's low-dim observation of `d`.

    robosuite computes Can/Square's object-in-gripper-frame entries (``<obj>_to_robot0_eef_*``)
    before it refreshes the object's own pose, so they combine the current gripper pose with
    the object pose of the previous observation, and are zero right after reset (empty cache).
    robomimic's data carry that convention, so it is reproduced here: pass the previous
    observation's object pose, or None at reset.
    """
    i = idx
    eef_pos = d.site_xpos[i["eef_site"]]
    eef_quat_wxyz = d.xquat[i["eef_body"]]
    obj_pos = d.xpos[i["obj_body"]]
    obj_quat_wxyz = d.xquat[i["obj_body"]]
    r_eef = d.xmat[i["eef_body"]]
    parts = []
    for key in meta["object_obs_keys"]:
        if key.startswith("gripper_to_"):
            parts.append(obj_pos - eef_pos)
        elif key.endswith("_to_robot0_eef_pos"):
            parts.append(jnp.zeros(3) if prev_obj_pos is None else r_eef.T @ (prev_obj_pos - eef_pos))
        elif key.endswith("_to_robot0_eef_quat"):
            parts.append(jnp.zeros(4) if prev_obj_mat is None else mat_to_quat_xyzw(r_eef.T @ prev_obj_mat))
        elif key.endswith("_pos"):
            parts.append(obj_pos)
        elif key.endswith("_quat"):
            parts.append(wxyz_to_xyzw(obj_quat_wxyz))
        else:
            raise ModelFileError(f"object observation key {key!r} is not supported")
    return {
        "robot0_eef_pos": eef_pos,
        "robot0_eef_quat": wxyz_to_xyzw(eef_quat_wxyz),
        "robot0_gripper_qpos": d.qpos[i["grip_qpos"]],
        "object": jnp.concatenate(parts),
    }


def object_pose(idx: dict, d: mjx.Data) -> tuple[jax.Array, jax.Array]:
    """The object body's world position and rotation matrix."""
    return d.xpos[idx["obj_body"]], d.xmat[idx["obj_body"]]


def check_success(task: str, idx: dict, meta: dict, d: mjx.Data) -> jax.Array:
    """robosuite's ``_check_success`` for `task`: Lift's cube above the table by the margin; the can in
    its bin, or the nut around its peg and low enough, with the gripper away from the object."""
    i, s = idx, meta["success"]
    obj = d.xpos[i["obj_body"]]
    if task == "lift":
        return obj[2] > s["table_height"] + s["lift_margin"]
    far = jnp.linalg.norm(d.site_xpos[i["eef_site"]] - obj) > s["min_gripper_distance"]
    if task == "pick_place_can":
        lo, hi = jnp.asarray(s["bin_low"]), jnp.asarray(s["bin_high"])
        return jnp.all((obj > lo) & (obj < hi)) & far
    peg = d.xpos[i["peg_body"]]
    near = (jnp.abs(obj[0] - peg[0]) < s["xy_tolerance"]) & (jnp.abs(obj[1] - peg[1]) < s["xy_tolerance"])
    return near & (obj[2] < s["max_height"]) & far


def flatten_obs(obs: dict[str, jax.Array], keys=OBS_KEYS) -> jax.Array:
    """Concatenate robomimic's low-dim keys (in `keys` order) into one vector (batched or not)."""
    return jnp.concatenate([obs[k] for k in keys], axis=-1)
