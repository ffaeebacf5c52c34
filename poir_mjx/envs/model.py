"""The exported MuJoCo model of a task: loading it, its object-size variants, and the indices an environment reads."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np
from mujoco import mjx

from poir_mjx.envs.physics import REFERENCE, PhysicsConfig, edit_spec
from poir_mjx.envs.tasks import task_files
from poir_mjx.envs.variants import ModelVariants, compile_variant, variant_sizes


class ModelFileError(ValueError):
    """An exported model file is missing or invalid; the message names the file (and field)."""


def load_model(task: str, envs_dir: str | Path | None = None,
               physics: PhysicsConfig = REFERENCE) -> tuple[mujoco.MjModel, dict]:  # fmt: skip
    """Compile envs/<task>.xml (meshes from envs/assets/, no robosuite needed) with `physics`'s solver options
    (the default: the exported ones) and read its metadata."""
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
    edit_spec(spec, physics)
    try:
        model = spec.compile()
    except Exception as e:  # mujoco raises ValueError with the parser's message
        raise ModelFileError(f"{files.xml}: does not compile ({e})") from e
    if meta.get("task") != task:
        raise ModelFileError(f"{files.meta}: field 'task' is {meta.get('task')!r}, expected {task!r}")
    return model, meta


def put_model(mj_model: mujoco.MjModel, physics: PhysicsConfig = REFERENCE) -> mjx.Model:
    """The MJX model of `mj_model` in the implementation `physics` asks for (MJX's JAX pipeline or MuJoCo Warp)."""
    return mjx.put_model(mj_model, impl="warp") if physics.impl == "warp" else mjx.put_model(mj_model)


def load_variants(task: str, envs_dir: str | Path | None, mj_model: mujoco.MjModel, model: mjx.Model,
                  meta: dict, physics: PhysicsConfig = REFERENCE) -> ModelVariants | None:  # fmt: skip
    """The per-episode object-size variants (variant 0 is `model`), or None for a task without ``object_size``."""
    if "object_size" not in meta:
        return None
    files = task_files(task, envs_dir)
    gid = mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_GEOM, meta["object_size"]["geom"])
    sizes = variant_sizes(meta, mj_model.geom_size[gid])
    xml, meshdir = files.xml.read_text(), str(files.xml.parent.resolve()) + "/"
    edit = lambda spec: edit_spec(spec, physics)  # noqa: E731
    models = [model] + [put_model(compile_variant(xml, meshdir, meta, sz, edit), physics) for sz in sizes[1:]]
    return ModelVariants.build(models, sizes)


def ids(model: mujoco.MjModel, kind: mujoco.mjtObj, names) -> np.ndarray:
    """The ids of the named objects of one kind (joints, bodies, ...); a missing name is a ModelFileError."""
    out = []
    for n in names:
        i = mujoco.mj_name2id(model, kind, n)
        if i < 0:
            raise ModelFileError(f"{kind.name} {n!r} not found in the exported model")
        out.append(i)
    return np.array(out, dtype=np.int32)


def model_indices(task: str, m: mujoco.MjModel, meta: dict) -> dict:
    """Where the environment reads and writes: qpos/dof addresses, actuators, sites and bodies (numpy ints)."""
    c, obj = meta["controller"], mujoco.mjtObj
    arm_j = ids(m, obj.mjOBJ_JOINT, c["arm_joints"])
    grip_j = ids(m, obj.mjOBJ_JOINT, c["gripper_joints"])
    obj_j = ids(m, obj.mjOBJ_JOINT, [meta["object_joint"]])[0]
    idx = dict(
        arm_qpos=m.jnt_qposadr[arm_j],
        arm_dof=m.jnt_dofadr[arm_j],
        grip_qpos=m.jnt_qposadr[grip_j],
        obj_qpos=int(m.jnt_qposadr[obj_j]),
        arm_act=ids(m, obj.mjOBJ_ACTUATOR, c["arm_actuators"]),
        grip_act=ids(m, obj.mjOBJ_ACTUATOR, c["gripper_actuators"]),
        eef_site=int(ids(m, obj.mjOBJ_SITE, [c["eef_site"]])[0]),
        origin_site=int(ids(m, obj.mjOBJ_SITE, [c["origin_site"]])[0]),
        eef_body=int(ids(m, obj.mjOBJ_BODY, [c["eef_body"]])[0]),
        obj_body=int(ids(m, obj.mjOBJ_BODY, [meta["object_body"]])[0]),
    )
    if task == "nut_assembly_square":
        idx["peg_body"] = int(ids(m, obj.mjOBJ_BODY, [meta["success"]["peg_body"]])[0])
    return idx
