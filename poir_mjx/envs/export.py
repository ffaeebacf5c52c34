"""Export robosuite tasks to MJX-ready MJCF (``make envs``).

Each task is built with robosuite itself (Panda, OSC_POSE, robomimic's settings), its compiled
MJCF is edited with ``mujoco.MjSpec`` and written to ``envs/<task>.xml`` together with
``envs/<task>.json``: the facts the JAX environment needs that are not in the MJCF (initial
joints, controller gains, placement samplers, success thresholds, observation layout).

The edits are deterministic and each one is listed, with its reason, in ``envs/README.md``:

1. freeze every body's inertia (mass, centre, principal inertia) as robosuite's model computed
   it, so that removing or simplifying geoms below cannot change the dynamics;
2. drop every non-colliding geom (visual meshes, helper markers), textures and materials;
3. drop the arm-link and mount collision meshes (MJX cost; the arm never touches the scene in
   the tasks' workspace) -- hand, fingers and finger pads keep colliding;
4. drop parked distractor objects (PickPlaceCan's milk, bread and cereal, their visual
   markers; NutAssemblySquare's round nut) that robosuite keeps far away at (10, 10, 10);
5. replace colliding cylinders (Square's pegs) and the 2868-vertex can mesh by 16-sided convex
   prisms (MJX lacks cylinder-box/mesh collisions; fewer vertices keep convex collision cheap);
6. the few mesh files the models still reference (the Panda finger) are copied into
   ``envs/assets/`` with robosuite's licence and referenced relative to ``envs/``, so loading a
   model needs no robosuite (byte-identical output on every machine);
7. the hand's (palm's) collision mesh becomes its bounding box in the mesh frame: MJX's
   mesh-box contact with the nut's thin walls produced a spurious impulse that launched the nut.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np

from poir_mjx.atomic import atomic_write_bytes, atomic_write_text
from poir_mjx.envs.tasks import (
    ASSETS_DIR,
    CONTROL_FREQ,
    EXPORT_SEED,
    HORIZON,
    OBJECT_BODY,
    OBJECT_SIZE_RANGE,
    TASKS,
    check_task,
    make_robosuite,
    task_files,
)

PRISM_SIDES = 16
# Bodies robosuite parks out of the workspace in the single-object variants of the tasks.
DISTRACTOR_PREFIXES = {
    "lift": (),
    "pick_place_can": ("Milk_", "Bread_", "Cereal_", "VisualMilk_", "VisualBread_", "VisualCereal_", "VisualCan_"),
    "nut_assembly_square": ("RoundNut_",),
}
# Collision meshes replaced by their bounding box (edit 7): MJX's mesh-box contact between the
# palm and the nut's thin walls launched the 16 g nut (measured, seed 1 of the fidelity test).
BOX_MESHES = ("gripper0_right_hand_collision",)
# Collision geoms removed for MJX cost (edit 3).
DROP_COLLISION_PREFIXES = ("robot0_link", "fixed_mount0_", "robot0_base", "mount0_")


def robosuite_root() -> Path:
    from poir_mjx.optional import require_robosuite

    return Path(require_robosuite("exporting the tasks (make envs)").__file__).resolve().parent


def robosuite_assets() -> Path:
    """robosuite's models/assets/ folder: exported mesh paths are relative to it, under envs/assets/."""
    return robosuite_root() / "models" / "assets"


def robosuite_license() -> str:
    """robosuite's licence text (from its installed distribution), shipped beside the copied assets."""
    from importlib.metadata import distribution

    dist = distribution("robosuite")
    for f in dist.files or ():
        if f.name == "LICENSE":
            return f.read_text()
    raise RuntimeError("robosuite's LICENSE file is not in its installed distribution")


def _fmt(x) -> list:
    return [float(f"{v:.10g}") for v in np.asarray(x, dtype=np.float64).ravel()]


def _prism_vertices(radius: float, z_low: float, z_high: float, center_xy=(0.0, 0.0)) -> np.ndarray:
    ang = 2 * np.pi * np.arange(PRISM_SIDES) / PRISM_SIDES
    ring = np.stack([center_xy[0] + radius * np.cos(ang), center_xy[1] + radius * np.sin(ang)], -1)
    low = np.concatenate([ring, np.full((PRISM_SIDES, 1), z_low)], -1)
    high = np.concatenate([ring, np.full((PRISM_SIDES, 1), z_high)], -1)
    return np.round(np.concatenate([low, high]), 6)


def _quat_to_mat(q) -> np.ndarray:
    import mujoco

    m = np.zeros(9)
    mujoco.mju_quat2Mat(m, np.asarray(q, dtype=np.float64))
    return m.reshape(3, 3)


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


def build_spec(task: str):
    """Build the task with robosuite and return (edited MjSpec, metadata dict, robosuite model)."""
    import mujoco

    check_task(task)
    robosuite_root()  # a clear error first if robosuite is missing
    env = make_robosuite(task, seed=EXPORT_SEED)
    env.reset()
    m0 = env.sim.model._model
    xml = env.sim.model.get_xml()
    root = str(robosuite_root()) + "/"
    assets = str(robosuite_assets()) + "/"
    spec = mujoco.MjSpec.from_string(xml)
    spec.meshdir = root

    # Edit 1: freeze inertias as robosuite's compiled model has them.
    for body in spec.bodies[1:]:
        bid = mujoco.mj_name2id(m0, mujoco.mjtObj.mjOBJ_BODY, body.name) if body.name else -1
        if bid < 0:
            raise RuntimeError(f"{task}: body without a name in robosuite's model, cannot freeze its inertia")
        body.explicitinertial = True
        body.mass = float(m0.body_mass[bid])
        body.ipos = m0.body_ipos[bid].copy()
        body.iquat = m0.body_iquat[bid].copy()
        body.inertia = m0.body_inertia[bid].copy()
        body.fullinertia = np.full(6, np.nan)

    # Edit 4: distractor bodies (children first is not needed: delete removes the subtree).
    for body in list(spec.bodies[1:]):
        if body.name.startswith(DISTRACTOR_PREFIXES[task]):
            try:
                spec.delete(body)
            except Exception:  # already removed with its parent
                pass

    # Edits 2, 3, 5 on the geoms that remain.
    mesh_bodyverts = {}
    for geom in list(spec.geoms):
        colliding = geom.contype != 0 or geom.conaffinity != 0
        if not colliding or geom.name.startswith(DROP_COLLISION_PREFIXES):
            spec.delete(geom)
            continue
        geom.material = ""
        if geom.type == mujoco.mjtGeom.mjGEOM_CYLINDER:
            r, h = float(geom.size[0]), float(geom.size[1])
            name = f"{geom.name or 'cyl'}_prism{len(mesh_bodyverts)}"
            spec.add_mesh(name=name, uservert=_prism_vertices(r, -h, h).ravel())
            mesh_bodyverts[name] = None
            geom.type = mujoco.mjtGeom.mjGEOM_MESH
            geom.meshname = name
        elif geom.type == mujoco.mjtGeom.mjGEOM_MESH and geom.name in BOX_MESHES:
            # Edit 7: the hand's mesh becomes its bounding box in the mesh's own (inertial) frame.
            gid = mujoco.mj_name2id(m0, mujoco.mjtObj.mjOBJ_GEOM, geom.name)
            mid = m0.geom_dataid[gid]
            v = m0.mesh_vert[m0.mesh_vertadr[mid] : m0.mesh_vertadr[mid] + m0.mesh_vertnum[mid]]
            lo, hi = v.min(0), v.max(0)
            geom.type = mujoco.mjtGeom.mjGEOM_BOX
            geom.meshname = ""
            geom.size = np.round((hi - lo) / 2, 6)
            geom.pos = np.round(m0.geom_pos[gid] + _quat_to_mat(m0.geom_quat[gid]) @ ((hi + lo) / 2), 6)
            geom.quat = np.round(m0.geom_quat[gid], 6)
        elif geom.type == mujoco.mjtGeom.mjGEOM_MESH and task == "pick_place_can" and geom.name == "Can_g0":
            gid = mujoco.mj_name2id(m0, mujoco.mjtObj.mjOBJ_GEOM, geom.name)
            mid = m0.geom_dataid[gid]
            v = m0.mesh_vert[m0.mesh_vertadr[mid] : m0.mesh_vertadr[mid] + m0.mesh_vertnum[mid]]
            vb = v @ _quat_to_mat(m0.geom_quat[gid]).T + m0.geom_pos[gid]  # vertices in the body frame
            cxy = (vb[:, :2].max(0) + vb[:, :2].min(0)) / 2
            radius = float(np.sqrt(((vb[:, :2] - cxy) ** 2).sum(-1)).max())
            name = "Can_prism"
            spec.add_mesh(name=name, uservert=_prism_vertices(radius, vb[:, 2].min(), vb[:, 2].max(), cxy).ravel())
            geom.meshname = name
            geom.pos = np.zeros(3)
            geom.quat = np.array([1.0, 0, 0, 0])

    used = {g.meshname for g in spec.geoms if g.type == mujoco.mjtGeom.mjGEOM_MESH}
    for mesh in list(spec.meshes):
        if mesh.name not in used:
            spec.delete(mesh)
        elif mesh.file:
            f = str(Path(spec.meshdir, mesh.file)) if not os.path.isabs(mesh.file) else mesh.file
            if not f.startswith(assets):
                raise RuntimeError(f"{task}: mesh {mesh.name} file {f} is outside robosuite's models/assets")
            mesh.file = f"{ASSETS_DIR}/{f[len(assets):]}"
    # "assets/..." resolves in robosuite's models/ folder here, in envs/ once exported.
    spec.meshdir = str(robosuite_assets().parent) + "/"
    for mat in list(spec.materials):
        spec.delete(mat)
    for tex in list(spec.textures):
        spec.delete(tex)

    obs = env._get_observations(force_update=True)
    meta = {
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
    return spec, meta, m0


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


def export_task(task: str) -> tuple[str, str]:
    """Return (xml text, json text) of the exported task."""
    spec, meta, _ = build_spec(task)
    spec.compile()  # fails loudly if an edit broke the model
    xml = spec.to_xml()
    # Mesh files are resolved against envs/ by load_model (edit 6).
    marker = f' meshdir="{spec.meshdir}"'
    if xml.count(marker) != 1:
        raise RuntimeError(f"{task}: expected one compiler meshdir attribute in the exported XML")
    xml = xml.replace(marker, "")
    return xml, json.dumps(meta, indent=2, sort_keys=True) + "\n"


def referenced_assets(xml: str) -> list[str]:
    """The asset files (paths relative to envs/) an exported model references."""
    import re

    return sorted(set(re.findall(rf'file="({ASSETS_DIR}/[^"]+)"', xml)))


def asset_files(xmls: list[str]) -> dict[str, bytes]:
    """{path relative to envs/: bytes} of every asset the models reference, plus robosuite's licence."""
    src = robosuite_assets()
    out = {f"{ASSETS_DIR}/LICENSE-robosuite": robosuite_license().encode()}
    for rel in sorted({r for x in xmls for r in referenced_assets(x)}):
        out[rel] = (src / rel[len(ASSETS_DIR) + 1 :]).read_bytes()
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", default="envs", help="output folder (default: envs)")
    p.add_argument("--task", action="append", choices=TASKS, help="task to export (default: all)")
    p.add_argument("--check", action="store_true", help="only export the tasks whose files are missing")
    args = p.parse_args(argv)
    xmls = []
    for task in args.task or TASKS:
        files = task_files(task, args.out)
        if args.check and files.xml.exists() and files.meta.exists():
            xmls.append(files.xml.read_text())
            continue
        xml, meta = export_task(task)
        atomic_write_text(files.xml, xml)
        atomic_write_text(files.meta, meta)
        xmls.append(xml)
        print(f"wrote {files.xml} and {files.meta}")
    missing = [r for x in xmls for r in referenced_assets(x) if not (Path(args.out) / r).exists()]
    if not args.check or missing or not (Path(args.out) / ASSETS_DIR / "LICENSE-robosuite").exists():
        for rel, data in asset_files(xmls).items():
            atomic_write_bytes(Path(args.out) / rel, data)
        print(f"wrote {Path(args.out) / ASSETS_DIR}/ (meshes referenced by the models, robosuite's licence)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
