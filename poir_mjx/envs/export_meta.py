"""The facts the JAX environment needs that are not in a task's MJCF (``envs/<task>.json``), read from the
robosuite environment the export builds: timing, initial joints, controller gains, placement sampler,
success thresholds, observation layout, the object's size range."""

from __future__ import annotations

import numpy as np

from poir_mjx.envs.tasks import CONTROL_FREQ, HORIZON, OBJECT_BODY, OBJECT_SIZE_RANGE


def task_meta(env, task: str, m0) -> dict:
    """envs/<task>.json of the robosuite environment `env` (reset) whose compiled model is `m0`."""
    obs = env._get_observations(force_update=True)
    return {
        "task": task,
        "robosuite_env": type(env).__name__,
        "control_freq": CONTROL_FREQ,
        "horizon": HORIZON,
        "timestep": float(m0.opt.timestep),
        "substeps": int(round(1.0 / CONTROL_FREQ / m0.opt.timestep)),
        "init_qpos": _fmt(env.robots[0].init_qpos),
        "gripper_init_qpos": _fmt(env.robots[0].gripper["right"].init_qpos),
        "controller": _controller_meta(env),
        "object_body": OBJECT_BODY[task],
        "object_joint": env.sim.model.joint_id2name(
            env.sim.model.body_jntadr[env.sim.model.body_name2id(OBJECT_BODY[task])]
        ),
        "placement": _placement_meta(env, task),
        "success": _success_meta(env, task),
        "object_obs_keys": [
            k for k in obs if k in env._observables and env._observables[k].modality == "object"
        ],
        "object_obs_size": int(obs["object-state"].shape[0]),
        **_object_size_meta(env, task),
    }


def _fmt(x) -> list:
    return [float(f"{v:.10g}") for v in np.asarray(x, dtype=np.float64).ravel()]


def _placement_meta(env, task: str) -> dict:
    """The robosuite placement sampler for the task's object, as plain numbers."""
    sampler = env.placement_initializer
    subs = sampler.samplers if hasattr(sampler, "samplers") else {"s": sampler}
    obj_name = OBJECT_BODY[task][: -len("_main")]
    for s in subs.values():
        for obj in s.mujoco_objects:
            if obj.name == obj_name:
                return {
                    "x_range": _fmt(s.x_range),
                    "y_range": _fmt(s.y_range),
                    "rotation": None if s.rotation is None else _fmt(np.atleast_1d(s.rotation)),
                    "rotation_axis": s.rotation_axis,
                    "ensure_object_boundary_in_range": bool(s.ensure_object_boundary_in_range),
                    "reference_pos": _fmt(s.reference_pos),
                    "z_offset": float(s.z_offset),
                    "horizontal_radius": float(obj.horizontal_radius),
                    "bottom_offset": _fmt(obj.bottom_offset),
                    "init_quat": _fmt(getattr(obj, "init_quat", [1.0, 0.0, 0.0, 0.0])),
                }
    raise RuntimeError(f"no placement sampler found for {obj_name} in {task}")


def _success_meta(env, task: str) -> dict:
    if task == "lift":
        return {"table_height": float(env.model.mujoco_arena.table_offset[2]), "lift_margin": 0.04}
    if task == "pick_place_can":
        i = env.object_to_id["can"]
        x_low, y_low = float(env.bin2_pos[0]), float(env.bin2_pos[1])
        if i in (0, 2):
            x_low -= env.bin_size[0] / 2
        if i < 2:
            y_low -= env.bin_size[1] / 2
        return {
            "bin_low": [x_low, y_low, float(env.bin2_pos[2])],
            "bin_high": [x_low + env.bin_size[0] / 2, y_low + env.bin_size[1] / 2, float(env.bin2_pos[2]) + 0.1],
            # r_reach = 1 - tanh(10 d) < 0.6  <=>  d > atanh(0.4) / 10
            "min_gripper_distance": float(np.arctanh(0.4) / 10.0),
        }
    if task == "nut_assembly_square":
        return {
            "peg_body": "peg1",
            "xy_tolerance": 0.03,
            "max_height": float(env.table_offset[2] + 0.05),
            "min_gripper_distance": float(np.arctanh(0.4) / 10.0),
        }
    raise AssertionError(task)


def _controller_meta(env) -> dict:
    robot = env.robots[0]
    arm = robot.part_controllers["right"]
    return {
        "type": arm.name,
        "kp": _fmt(arm.kp),
        "kd": _fmt(arm.kd),
        "input_min": _fmt(arm.input_min),
        "input_max": _fmt(arm.input_max),
        "output_min": _fmt(arm.output_min),
        "output_max": _fmt(arm.output_max),
        "nullspace_kp": 10.0,
        "ref_site": arm.ref_name,
        "origin_site": "robot0_right_center",
        "arm_joints": list(robot.robot_model.joints),
        "arm_actuators": list(robot.robot_model.actuators),
        "gripper_joints": list(robot.gripper["right"].joints),
        "gripper_actuators": list(robot.gripper["right"].actuators),
        "gripper_speed": float(robot.gripper["right"].speed),
        "eef_body": robot.robot_model.eef_name["right"],
        "eef_site": arm.ref_name,
    }


def _object_size_meta(env, task: str) -> dict:
    """Lift's cube: robosuite draws its half-sizes per axis in OBJECT_SIZE_RANGE at every reset
    (BoxObject, density from the built model); the other tasks' objects have fixed sizes."""
    if task not in OBJECT_SIZE_RANGE:
        return {}
    m = env.sim.model
    geom = OBJECT_SIZE_RANGE[task]["geom"]
    g, b = m.geom_name2id(geom), m.body_name2id(OBJECT_BODY[task])
    density = float(m.body_mass[b] / (8.0 * np.prod(m.geom_size[g])))
    lo, hi = OBJECT_SIZE_RANGE[task]["size_min"], OBJECT_SIZE_RANGE[task]["size_max"]
    return {"object_size": {"geom": geom, "size_min": lo, "size_max": hi, "density": round(density, 3)}}
