"""Pure, jit- and vmap-able robosuite tasks stepped in MJX.

``env = make_env("lift")``; ``state = env.reset(rng, params)``; ``state = env.step(state, action)``.
Nothing mutates: ``State`` is a pytree. A control step is robosuite's: 25 physics substeps of
2 ms under ``lax.scan``, OSC_POSE torques recomputed on each substep (``osc.py``).
"""

from __future__ import annotations

import dataclasses
import functools
import json
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct
from mujoco import mjx

from poir_mjx.compat import x64_enabled
from poir_mjx.envs import osc
from poir_mjx.envs.tasks import check_task, task_files
from poir_mjx.envs.variants import ModelVariants, compile_variant, variant_sizes

ACTION_SIZE = 7
# robomimic's low-dim observation keys (object last), with the sizes for each task.
OBS_KEYS = ("robot0_eef_pos", "robot0_eef_quat", "robot0_gripper_qpos", "object")


@struct.dataclass
class EnvParams:
    """Per-episode perturbation parameters (a batch of these covers a whole noise grid)."""

    sigma_init: jax.Array  # std of Gaussian noise on the 7 initial arm joints (robosuite default 0.02)
    sigma_action: jax.Array  # std of Gaussian noise added to every action before the controller


def float_dtype():
    """float32, or float64 when jax_enable_x64 is on (MJX then runs in double precision)."""
    return jnp.zeros(()).dtype


def make_params(sigma_init=0.02, sigma_action=0.0) -> EnvParams:
    """Build (possibly batched) EnvParams; negative or non-finite noise levels are rejected."""
    si = np.asarray(sigma_init, dtype=np.float32)
    sa = np.asarray(sigma_action, dtype=np.float32)
    for name, v in (("sigma_init", si), ("sigma_action", sa)):
        if not np.all(np.isfinite(v)) or np.any(v < 0):
            raise ValueError(f"{name}: noise level must be finite and >= 0, got {v.tolist()}")
    si, sa = np.broadcast_arrays(si, sa)
    return EnvParams(sigma_init=jnp.asarray(si, float_dtype()), sigma_action=jnp.asarray(sa, float_dtype()))


@struct.dataclass
class State:
    data: mjx.Data
    obs: dict[str, jax.Array]
    done: jax.Array  # episode over: horizon reached or physics diverged
    success: jax.Array  # robosuite's _check_success at this step
    info: dict[str, Any]


class ModelFileError(ValueError):
    pass


def load_model(task: str, envs_dir: str | Path | None = None) -> tuple[mujoco.MjModel, dict]:
    """Compile envs/<task>.xml (meshes from envs/assets/, no robosuite needed) and read its metadata."""
    files = task_files(task, envs_dir)
    for f in (files.xml, files.meta):
        if not f.exists():
            raise ModelFileError(f"{f}: missing; run `make envs` to export the robosuite tasks")
    try:
        meta = json.loads(files.meta.read_text())
    except json.JSONDecodeError as e:
        raise ModelFileError(f"{files.meta}: not valid JSON ({e})") from e
    spec = mujoco.MjSpec.from_string(files.xml.read_text())
    spec.meshdir = str(files.xml.parent.resolve()) + "/"
    try:
        model = spec.compile()
    except Exception as e:  # mujoco raises ValueError with the parser's message
        raise ModelFileError(f"{files.xml}: does not compile ({e})") from e
    if meta.get("task") != task:
        raise ModelFileError(f"{files.meta}: field 'task' is {meta.get('task')!r}, expected {task!r}")
    return model, meta


def _ids(model, kind, names):
    out = []
    for n in names:
        i = mujoco.mj_name2id(model, kind, n)
        if i < 0:
            raise ModelFileError(f"{kind.name} {n!r} not found in the exported model")
        out.append(i)
    return np.array(out, dtype=np.int32)


def _quat_xyzw(q_wxyz):
    return jnp.concatenate([q_wxyz[..., 1:], q_wxyz[..., :1]], -1)


def _mat_to_quat_xyzw(r):
    """robosuite's mat2quat (unit quaternion, w >= 0), returned as (x, y, z, w)."""
    q = mjx_mat2quat(r)
    q = jnp.where(q[0] < 0, -q, q)
    return _quat_xyzw(q)


def mjx_mat2quat(r):
    """Shepperd's method, branch-free: quaternion (w, x, y, z) of a rotation matrix."""
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


def _quat_mul(a, b):
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


@dataclasses.dataclass(frozen=True, eq=False)
class TaskEnv:
    """A robosuite task in MJX. Static configuration only; all episode data lives in ``State``."""

    task: str
    mj_model: mujoco.MjModel
    model: mjx.Model
    meta: dict
    variants: ModelVariants | None = None  # per-episode object sizes (Lift), variant 0 = `model`

    def model_for(self, variant) -> mjx.Model:
        """The episode's model: `model`, or its object-size variant (``info["variant"]``)."""
        return self.model if self.variants is None else self.variants.model(variant)

    # ---- static indices (numpy) -------------------------------------------------------------
    @functools.cached_property
    def _idx(self) -> dict:
        m, c = self.mj_model, self.meta["controller"]
        arm_j = _ids(m, mujoco.mjtObj.mjOBJ_JOINT, c["arm_joints"])
        grip_j = _ids(m, mujoco.mjtObj.mjOBJ_JOINT, c["gripper_joints"])
        obj_j = _ids(m, mujoco.mjtObj.mjOBJ_JOINT, [self.meta["object_joint"]])[0]
        arm_a = _ids(m, mujoco.mjtObj.mjOBJ_ACTUATOR, c["arm_actuators"])
        grip_a = _ids(m, mujoco.mjtObj.mjOBJ_ACTUATOR, c["gripper_actuators"])
        idx = dict(
            arm_qpos=m.jnt_qposadr[arm_j],
            arm_dof=m.jnt_dofadr[arm_j],
            grip_qpos=m.jnt_qposadr[grip_j],
            obj_qpos=int(m.jnt_qposadr[obj_j]),
            arm_act=arm_a,
            grip_act=grip_a,
            eef_site=int(_ids(m, mujoco.mjtObj.mjOBJ_SITE, [c["eef_site"]])[0]),
            origin_site=int(_ids(m, mujoco.mjtObj.mjOBJ_SITE, [c["origin_site"]])[0]),
            eef_body=int(_ids(m, mujoco.mjtObj.mjOBJ_BODY, [c["eef_body"]])[0]),
            obj_body=int(_ids(m, mujoco.mjtObj.mjOBJ_BODY, [self.meta["object_body"]])[0]),
        )
        if self.task == "nut_assembly_square":
            idx["peg_body"] = int(_ids(m, mujoco.mjtObj.mjOBJ_BODY, [self.meta["success"]["peg_body"]])[0])
        return idx

    @property
    def action_size(self) -> int:
        return ACTION_SIZE

    @property
    def obs_sizes(self) -> dict[str, int]:
        return {"robot0_eef_pos": 3, "robot0_eef_quat": 4, "robot0_gripper_qpos": 2, "object": self.meta["object_obs_size"]}

    @property
    def horizon(self) -> int:
        return int(self.meta["horizon"])

    # ---- observations and success ------------------------------------------------------------
    def observe(self, d: mjx.Data, prev_obj_pos=None, prev_obj_mat=None) -> dict[str, jax.Array]:
        """robomimic's low-dim observation of `d`.

        robosuite computes Can/Square's object-in-gripper-frame entries (``<obj>_to_robot0_eef_*``)
        before it refreshes the object's own pose, so they combine the current gripper pose with
        the object pose of the previous observation, and are zero right after reset (empty cache).
        robomimic's data carry that convention, so it is reproduced here: pass the previous
        observation's object pose, or None at reset.
        """
        i = self._idx
        eef_pos = d.site_xpos[i["eef_site"]]
        eef_quat_wxyz = d.xquat[i["eef_body"]]
        obj_pos = d.xpos[i["obj_body"]]
        obj_quat_wxyz = d.xquat[i["obj_body"]]
        r_eef = d.xmat[i["eef_body"]]
        parts = []
        for key in self.meta["object_obs_keys"]:
            if key.startswith("gripper_to_"):
                parts.append(obj_pos - eef_pos)
            elif key.endswith("_to_robot0_eef_pos"):
                parts.append(jnp.zeros(3) if prev_obj_pos is None else r_eef.T @ (prev_obj_pos - eef_pos))
            elif key.endswith("_to_robot0_eef_quat"):
                parts.append(jnp.zeros(4) if prev_obj_mat is None else _mat_to_quat_xyzw(r_eef.T @ prev_obj_mat))
            elif key.endswith("_pos"):
                parts.append(obj_pos)
            elif key.endswith("_quat"):
                parts.append(_quat_xyzw(obj_quat_wxyz))
            else:
                raise ModelFileError(f"object observation key {key!r} is not supported")
        return {
            "robot0_eef_pos": eef_pos,
            "robot0_eef_quat": _quat_xyzw(eef_quat_wxyz),
            "robot0_gripper_qpos": d.qpos[i["grip_qpos"]],
            "object": jnp.concatenate(parts),
        }

    def _object_pose(self, d: mjx.Data):
        return d.xpos[self._idx["obj_body"]], d.xmat[self._idx["obj_body"]]

    def check_success(self, d: mjx.Data) -> jax.Array:
        i, s = self._idx, self.meta["success"]
        obj = d.xpos[i["obj_body"]]
        if self.task == "lift":
            return obj[2] > s["table_height"] + s["lift_margin"]
        far = jnp.linalg.norm(d.site_xpos[i["eef_site"]] - obj) > s["min_gripper_distance"]
        if self.task == "pick_place_can":
            lo, hi = jnp.asarray(s["bin_low"]), jnp.asarray(s["bin_high"])
            return jnp.all((obj > lo) & (obj < hi)) & far
        peg = d.xpos[i["peg_body"]]
        near = (jnp.abs(obj[0] - peg[0]) < s["xy_tolerance"]) & (jnp.abs(obj[1] - peg[1]) < s["xy_tolerance"])
        return near & (obj[2] < s["max_height"]) & far

    # ---- reset ---------------------------------------------------------------------------------
    def _sample_object_pose(self, rng):
        p = self.meta["placement"]
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
        return pos, _quat_mul(quat, jnp.asarray(p["init_quat"]))

    def reset_to(self, qpos: jax.Array, rng: jax.Array, params: EnvParams, variant=0) -> State:
        """Start an episode from a given qpos (arm, gripper and object as laid out in the model), with
        object-size variant `variant` (0: the exported model)."""
        i = self._idx
        m = self.model_for(variant)
        d = mjx.make_data(self.model).replace(qpos=jnp.asarray(qpos, float_dtype()))
        d = mjx.forward(m, d)
        info = {
            "variant": jnp.asarray(variant, jnp.int32),
            "rng": rng,
            "step": jnp.zeros((), jnp.int32),
            "first_success": jnp.full((), -1, jnp.int32),
            "diverged": jnp.zeros((), bool),
            "gripper_cmd": jnp.zeros(2),
            "initial_joint": qpos[i["arm_qpos"]],
            "sigma_action": jnp.asarray(params.sigma_action, float_dtype()),
        }
        info["prev_obj_pos"], info["prev_obj_mat"] = self._object_pose(d)
        success = self.check_success(d)
        return State(data=d, obs=self.observe(d), done=jnp.zeros((), bool), success=success, info=info)

    def obs_vector(self, state: State) -> jax.Array:
        """The policy's input: robomimic's low-dim keys concatenated (``flatten_obs``)."""
        return flatten_obs(state.obs)

    def reset(self, rng: jax.Array, params: EnvParams) -> State:
        variant = 0
        if self.variants is not None:  # robosuite redraws Lift's cube size at every reset
            rng, k_var = jax.random.split(rng)
            variant = jax.random.randint(k_var, (), 0, self.variants.count)
        k_qpos, k_ep = jax.random.split(rng)
        return self.reset_to(self.sample_qpos(k_qpos, params, variant), k_ep, params, variant)

    def sample_qpos(self, rng: jax.Array, params: EnvParams, variant=0) -> jax.Array:
        """robosuite's reset distribution: noisy initial arm joints, object from its placement sampler
        (resting on the table whatever the variant's object height)."""
        i, meta = self._idx, self.meta
        k_init, k_obj = jax.random.split(rng)
        qpos = jnp.asarray(self.mj_model.qpos0, float_dtype())
        noise = jax.random.normal(k_init, (7,)) * params.sigma_init
        qpos = qpos.at[i["arm_qpos"]].set(jnp.asarray(meta["init_qpos"]) + noise)
        qpos = qpos.at[i["grip_qpos"]].set(jnp.asarray(meta["gripper_init_qpos"]))
        pos, quat = self._sample_object_pose(k_obj)
        if self.variants is not None:  # the placement's bottom offset is the box's half height
            pos = pos.at[2].add(self.variants.sizes[variant, 2] - self.variants.sizes[0, 2])
        return qpos.at[i["obj_qpos"] : i["obj_qpos"] + 7].set(jnp.concatenate([pos, quat]))

    # ---- step ----------------------------------------------------------------------------------
    def _arm_terms(self, m: mjx.Model, d: mjx.Data):
        i = self._idx
        jacp, jacr = mjx.jac(m, d, d.site_xpos[i["eef_site"]], self.mj_model.site_bodyid[i["eef_site"]])
        dof = i["arm_dof"]
        mass = mjx.full_m(m, d)[dof][:, dof]
        return jacp[dof].T, jacr[dof].T, mass

    def step(self, state: State, action: jax.Array) -> State:
        action = jnp.asarray(action)
        if action.shape != (ACTION_SIZE,):
            raise ValueError(f"action: expected shape ({ACTION_SIZE},) per episode, got {action.shape}")
        if not jnp.issubdtype(action.dtype, jnp.floating):
            raise ValueError(f"action: expected a floating-point dtype, got {action.dtype}")
        m, i, c = self.model_for(state.info["variant"]), self._idx, self.meta["controller"]
        rng, k_noise = jax.random.split(state.info["rng"])
        a = action.astype(float_dtype()) + state.info["sigma_action"] * jax.random.normal(k_noise, (ACTION_SIZE,))
        delta = osc.scale_action(
            a[:6], jnp.asarray(c["input_min"]), jnp.asarray(c["input_max"]),
            jnp.asarray(c["output_min"]), jnp.asarray(c["output_max"]),
        )  # fmt: skip
        grip_cmd = osc.gripper_command(state.info["gripper_cmd"], a[6], c["gripper_speed"])
        lo, hi = self.mj_model.actuator_ctrlrange[i["grip_act"]].T
        grip_ctrl = jnp.clip(0.5 * (hi + lo) + 0.5 * (hi - lo) * grip_cmd, lo, hi)
        arm_lo, arm_hi = (jnp.asarray(x) for x in self.mj_model.actuator_ctrlrange[i["arm_act"]].T)
        kp, kd = jnp.asarray(c["kp"]), jnp.asarray(c["kd"])

        def substep(carry, k):
            d, goal_pos, goal_ori = carry
            d = mjx.fwd_position(m, d)
            d = mjx.fwd_velocity(m, d)
            ref_pos = d.site_xpos[i["eef_site"]]
            ref_ori = d.site_xmat[i["eef_site"]]
            # The goal is set on the first substep from the then-current pose ('achieved' mode).
            new_pos, new_ori = osc.goal_from_delta(delta, ref_pos, ref_ori, d.site_xmat[i["origin_site"]])
            goal_pos = jnp.where(k == 0, new_pos, goal_pos)
            goal_ori = jnp.where(k == 0, new_ori, goal_ori)
            jac_pos, jac_ori, mass = self._arm_terms(m, d)
            tau = osc.osc_torques(
                goal_pos=goal_pos, goal_ori=goal_ori, ref_pos=ref_pos, ref_ori=ref_ori,
                jac_pos=jac_pos, jac_ori=jac_ori, qvel=d.qvel[i["arm_dof"]], qpos=d.qpos[i["arm_qpos"]],
                mass_matrix=mass, bias=d.qfrc_bias[i["arm_dof"]], initial_joint=state.info["initial_joint"],
                kp=kp, kd=kd, nullspace_kp=c["nullspace_kp"],
            )  # fmt: skip
            ctrl = d.ctrl.at[i["arm_act"]].set(jnp.clip(tau, arm_lo, arm_hi)).at[i["grip_act"]].set(grip_ctrl)
            d = d.replace(ctrl=ctrl)
            d = mjx.fwd_actuation(m, d)
            d = mjx.fwd_acceleration(m, d)
            d = mjx.solve(m, d)
            d = mjx.euler(m, d)
            return (d, goal_pos, goal_ori), None

        init = (state.data, jnp.zeros(3), jnp.eye(3))
        (d, _, _), _ = jax.lax.scan(substep, init, jnp.arange(self.meta["substeps"]))

        diverged = ~(jnp.all(jnp.isfinite(d.qpos)) & jnp.all(jnp.isfinite(d.qvel)))
        step = state.info["step"] + 1
        success = self.check_success(d) & ~diverged
        first = jnp.where((state.info["first_success"] < 0) & success, step, state.info["first_success"])
        obj_pos, obj_mat = self._object_pose(d)
        info = dict(
            state.info, rng=rng, step=step, first_success=first, diverged=diverged, gripper_cmd=grip_cmd,
            prev_obj_pos=obj_pos, prev_obj_mat=obj_mat,
        )  # fmt: skip
        obs = self.observe(d, state.info["prev_obj_pos"], state.info["prev_obj_mat"])
        new = State(data=d, obs=obs, done=diverged | (step >= self.horizon), success=success, info=info)
        # A diverged episode keeps its last finite state (flagged); a finished one stops changing.
        keep_old = state.done | diverged
        out = jax.tree_util.tree_map(lambda old, nw: jnp.where(keep_old, old, nw), state, new)
        return out.replace(
            done=state.done | new.done,
            info=dict(out.info, diverged=state.info["diverged"] | diverged),
        )


def make_env(task: str, envs_dir: str | None = None) -> TaskEnv:
    """The MJX environment for `task` (one of poir_mjx.envs.tasks.TASKS), in the current float precision.

    The MJX model's arrays take jax's default float (float64 inside ``compat.enable_x64()``), so one
    environment is kept per task and precision.
    """
    return _make_env(task, envs_dir, x64_enabled())


@functools.lru_cache(maxsize=None)
def _make_env(task: str, envs_dir: str | None, x64: bool) -> TaskEnv:
    check_task(task)
    mj_model, meta = load_model(task, envs_dir)
    model = mjx.put_model(mj_model)
    variants = None
    if "object_size" in meta:
        files = task_files(task, envs_dir)
        gid = mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_GEOM, meta["object_size"]["geom"])
        sizes = variant_sizes(meta, mj_model.geom_size[gid])
        xml, meshdir = files.xml.read_text(), str(files.xml.parent.resolve()) + "/"
        models = [model] + [mjx.put_model(compile_variant(xml, meshdir, meta, sz)) for sz in sizes[1:]]
        variants = ModelVariants.build(models, sizes)
    return TaskEnv(task=task, mj_model=mj_model, model=model, meta=meta, variants=variants)


def batched(task: str, envs_dir: str | None = None):
    """(reset, reset_to, step) jitted and vmapped over episodes; one compilation per batch shape."""
    return _batched(task, envs_dir, x64_enabled())


@functools.lru_cache(maxsize=None)
def _batched(task: str, envs_dir: str | None, x64: bool):
    env = _make_env(task, envs_dir, x64)
    return (
        jax.jit(jax.vmap(env.reset)),
        jax.jit(jax.vmap(env.reset_to)),
        jax.jit(jax.vmap(env.step)),
    )


def flatten_obs(obs: dict[str, jax.Array], keys=OBS_KEYS) -> jax.Array:
    """Concatenate robomimic's low-dim keys (in `keys` order) into one vector (batched or not)."""
    return jnp.concatenate([obs[k] for k in keys], axis=-1)
