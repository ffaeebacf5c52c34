"""Pure, jit- and vmap-able robosuite tasks stepped in MJX.

``env = make_env("lift")``; ``state = env.reset(rng, params)``; ``state = env.step(state, action)``.
Nothing mutates: ``State`` is a pytree. A control step is robosuite's: 25 physics substeps of
2 ms under ``lax.scan``, OSC_POSE torques recomputed on each substep (``osc.py``).

Beside it: the model files and index table (``model.py``), observation and success
(``observation.py``), the object placement at reset (``placement.py``), rotations (``rotation.py``),
the observation keys and action size (``layout.py``).
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct
from mujoco import mjx

from poir_mjx.cached import builder
from poir_mjx.compat import x64_enabled
from poir_mjx.envs import osc, warp
from poir_mjx.envs import observation
from poir_mjx.envs.layout import ACTION_SIZE, OBS_KEYS, obs_sizes, observation_keys
from poir_mjx.envs.model import ModelFileError, load_model, load_variants, model_indices, put_model
from poir_mjx.envs.observation import flatten_obs
from poir_mjx.envs.physics import REFERENCE, PhysicsConfig, as_physics, solver_scope
from poir_mjx.envs.placement import sample_object_pose
from poir_mjx.envs.tasks import check_task
from poir_mjx.envs.variants import ModelVariants

# What other modules take from here; the names defined beside (model, layout, observation) are kept
# importable from this module, the environment's front door.
__all__ = ["ACTION_SIZE", "OBS_KEYS", "EnvParams", "ModelFileError", "State", "TaskEnv", "batched", "flatten_obs",
           "float_dtype", "load_model", "make_env", "make_params"]  # fmt: skip


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


@dataclasses.dataclass(frozen=True, eq=False)
class TaskEnv:
    """A robosuite task in MJX. Static configuration only; all episode data lives in ``State``."""

    task: str
    mj_model: mujoco.MjModel
    model: mjx.Model
    meta: dict
    variants: ModelVariants | None = None  # per-episode object sizes (Lift), variant 0 = `model`
    observation: str = "low_dim"  # what obs_vector gives the policy: "low_dim" or "object" (layout.OBSERVATIONS)
    physics: PhysicsConfig = REFERENCE  # solver settings (physics.py), already in `model`'s options
    worlds: int = 1  # MuJoCo Warp only: the episodes of the batch being traced, which share the contact buffers

    @property
    def on_warp(self) -> bool:
        return self.physics.impl == "warp"

    def sized_for(self, worlds: int) -> TaskEnv:
        """This environment for a traced batch of `worlds` episodes (``rollout.protocol.for_batch``): MuJoCo Warp's
        shared contact buffers are sized by it when ``reset`` allocates; with MJX's JAX pipeline, itself."""
        return _sized(self, int(worlds)) if self.on_warp and worlds != self.worlds else self

    def model_for(self, variant) -> mjx.Model:
        """The episode's model: `model`, or its object-size variant (``info["variant"]``)."""
        return self.model if self.variants is None else self.variants.model(variant)

    # ---- static indices (numpy) -------------------------------------------------------------
    @functools.cached_property
    def _idx(self) -> dict:
        return model_indices(self.task, self.mj_model, self.meta)

    @property
    def action_size(self) -> int:
        return ACTION_SIZE

    @property
    def obs_sizes(self) -> dict[str, int]:
        return obs_sizes(self.meta)

    @property
    def obs_size(self) -> int:
        """The size of the policy's vector (``obs_vector``)."""
        return sum(self.obs_sizes[k] for k in observation_keys(self.observation))

    @property
    def horizon(self) -> int:
        return int(self.meta["horizon"])

    # ---- observations and success (observation.py) -------------------------------------------
    def observe(self, d: mjx.Data, prev_obj_pos=None, prev_obj_mat=None) -> dict[str, jax.Array]:
        """robomimic's low-dim observation of `d` (the previous observation's object pose, None at reset)."""
        return observation.observe(self._idx, self.meta, d, prev_obj_pos, prev_obj_mat)

    def _object_pose(self, d: mjx.Data):
        return observation.object_pose(self._idx, d)

    def check_success(self, d: mjx.Data) -> jax.Array:
        return observation.check_success(self.task, self._idx, self.meta, d)

    # ---- reset ---------------------------------------------------------------------------------
    def reset_to(self, qpos: jax.Array, rng: jax.Array, params: EnvParams, variant=0) -> State:
        """Start an episode from a given qpos (arm, gripper and object as laid out in the model), with
        object-size variant `variant` (0: the exported model)."""
        i = self._idx
        m = self.model_for(variant)
        if self.on_warp:  # the batch's shared contact buffers, allocated outside the trace (warp.py)
            d = warp.make_data(self.mj_model, self.worlds, self.physics.warp_contacts)
        else:
            d = mjx.make_data(self.model)
        d = d.replace(qpos=jnp.asarray(qpos, float_dtype()))
        with solver_scope(self.physics):
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
        """The policy's input: the observation's keys concatenated (``flatten_obs``); ``state.obs`` keeps every key."""
        return flatten_obs(state.obs, observation_keys(self.observation))

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
        pos, quat = sample_object_pose(k_obj, meta["placement"])
        if self.variants is not None:  # the placement's bottom offset is the box's half height
            pos = pos.at[2].add(self.variants.sizes[variant, 2] - self.variants.sizes[0, 2])
        return qpos.at[i["obj_qpos"] : i["obj_qpos"] + 7].set(jnp.concatenate([pos, quat]))

    # ---- step ----------------------------------------------------------------------------------
    def _arm_terms(self, m: mjx.Model, d: mjx.Data):
        i = self._idx
        jacp, jacr = mjx.jac(m, d, d.site_xpos[i["eef_site"]], self.mj_model.site_bodyid[i["eef_site"]])
        dof = i["arm_dof"]
        mass = (warp.full_m(self.mj_model, m, d) if self.on_warp else mjx.full_m(m, d))[dof][:, dof]
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
            if self.on_warp:  # Warp has forward and step only: robosuite's order (forward, controller, step)
                d = mjx.forward(m, d)
            else:
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
            if self.on_warp:
                return (mjx.step(m, d), goal_pos, goal_ori), None
            d = mjx.fwd_actuation(m, d)
            d = mjx.fwd_acceleration(m, d)
            d = mjx.solve(m, d)
            d = mjx.euler(m, d)
            return (d, goal_pos, goal_ori), None

        init = (state.data, jnp.zeros(3), jnp.eye(3))
        with solver_scope(self.physics):  # MJX's solver as the physics config asks (physics.py)
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
        keep = jax.tree_util.tree_map(lambda old, nw: jnp.where(keep_old, old, nw), state.replace(data=()),
                                      new.replace(data=()))  # fmt: skip
        return keep.replace(
            data=warp.keep_where(keep_old, state.data, new.data),
            done=state.done | new.done,
            info=dict(keep.info, diverged=state.info["diverged"] | diverged),
        )


def make_env(task: str, envs_dir: str | None = None, observation: str = "low_dim",
             physics: PhysicsConfig | str | None = None) -> TaskEnv:  # fmt: skip
    """The MJX environment for `task` (one of poir_mjx.envs.tasks.TASKS), in the current float precision, its
    policy vector the `observation`'s keys ("low_dim": robomimic's low-dim set; "object": the object-state alone),
    with `physics` (a PhysicsConfig or a preset name of ``physics.PHYSICS_PRESETS``; None: today's, "reference").

    The MJX model's arrays take jax's default float (float64 inside ``compat.enable_x64()``), so one
    environment is kept per task, precision and physics; the observations share its model.
    """
    observation_keys(observation)  # an unknown observation: one ValueError naming it
    env = _make_env(task, envs_dir, x64_enabled(), as_physics(physics))
    return env if observation == "low_dim" else _observed(env, observation)


@builder
def _observed(env: TaskEnv, observation: str) -> TaskEnv:
    return dataclasses.replace(env, observation=observation)


@builder
def _make_env(task: str, envs_dir: str | None, x64: bool, physics: PhysicsConfig = REFERENCE) -> TaskEnv:
    check_task(task)
    mj_model, meta = load_model(task, envs_dir, physics)
    model = put_model(mj_model, physics)
    variants = load_variants(task, envs_dir, mj_model, model, meta, physics)
    return TaskEnv(task=task, mj_model=mj_model, model=model, meta=meta, variants=variants, physics=physics)


@builder
def _sized(env: TaskEnv, worlds: int) -> TaskEnv:
    return dataclasses.replace(env, worlds=worlds)


def batched(task: str, envs_dir: str | None = None, physics: PhysicsConfig | str | None = None):
    """(reset, reset_to, step) jitted and vmapped over episodes; one compilation per batch shape."""
    return _batched(task, envs_dir, x64_enabled(), as_physics(physics))


@builder
def _batched(task: str, envs_dir: str | None, x64: bool, physics: PhysicsConfig = REFERENCE):
    env = _make_env(task, envs_dir, x64, physics)

    def reset(rng, params):
        return jax.vmap(env.sized_for(rng.shape[0]).reset)(rng, params)

    def reset_to(qpos, rng, params, *variant):
        return jax.vmap(env.sized_for(rng.shape[0]).reset_to)(qpos, rng, params, *variant)

    return jax.jit(reset), jax.jit(reset_to), jax.jit(jax.vmap(env.step))
