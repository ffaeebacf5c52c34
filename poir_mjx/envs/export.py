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

import json
import os
from pathlib import Path

import numpy as np

from poir_mjx.envs.export_meta import task_meta
from poir_mjx.envs.tasks import ASSETS_DIR, EXPORT_SEED, check_task, make_robosuite

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


def build_spec(task: str):
    """Build the task with robosuite and return (edited MjSpec, metadata dict, robosuite model)."""
    import mujoco

    check_task(task)
    root = str(robosuite_root()) + "/"  # a clear error first if robosuite is missing
    env = make_robosuite(task, seed=EXPORT_SEED)
    env.reset()
    m0 = env.sim.model._model
    spec = mujoco.MjSpec.from_string(env.sim.model.get_xml())
    spec.meshdir = root
    _freeze_inertias(spec, m0, task)
    _drop_distractors(spec, task)
    _edit_geoms(spec, m0, task)
    _relocate_meshes(spec, task)
    return spec, task_meta(env, task, m0), m0


def _freeze_inertias(spec, m0, task: str) -> None:
    """Edit 1: every body's inertia as robosuite's compiled model has it."""
    import mujoco

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


def _drop_distractors(spec, task: str) -> None:
    """Edit 4: the parked distractor bodies (delete removes a subtree: children need no visit)."""
    for body in list(spec.bodies[1:]):
        if body.name.startswith(DISTRACTOR_PREFIXES[task]):
            try:
                spec.delete(body)
            except Exception:  # already removed with its parent
                pass


def _edit_geoms(spec, m0, task: str) -> None:
    """Edits 2, 3, 5 and 7 on the geoms: drop the non-colliding and arm/mount ones, simplify the rest."""
    import mujoco

    prisms = 0
    for geom in list(spec.geoms):
        colliding = geom.contype != 0 or geom.conaffinity != 0
        if not colliding or geom.name.startswith(DROP_COLLISION_PREFIXES):
            spec.delete(geom)
            continue
        geom.material = ""
        if geom.type == mujoco.mjtGeom.mjGEOM_CYLINDER:
            _cylinder_to_prism(spec, geom, f"{geom.name or 'cyl'}_prism{prisms}")
            prisms += 1
        elif geom.type == mujoco.mjtGeom.mjGEOM_MESH and geom.name in BOX_MESHES:
            _mesh_to_box(geom, m0)
        elif geom.type == mujoco.mjtGeom.mjGEOM_MESH and task == "pick_place_can" and geom.name == "Can_g0":
            _can_to_prism(spec, geom, m0)


def _cylinder_to_prism(spec, geom, name: str) -> None:
    """Edit 5: a colliding cylinder (Square's pegs) becomes a 16-sided convex prism."""
    import mujoco

    r, h = float(geom.size[0]), float(geom.size[1])
    spec.add_mesh(name=name, uservert=_prism_vertices(r, -h, h).ravel())
    geom.type = mujoco.mjtGeom.mjGEOM_MESH
    geom.meshname = name


def _mesh_vertices(m0, geom_name: str) -> tuple[int, np.ndarray]:
    """(geom id, the vertices of its mesh in the mesh frame) in robosuite's compiled model."""
    import mujoco

    gid = mujoco.mj_name2id(m0, mujoco.mjtObj.mjOBJ_GEOM, geom_name)
    mid = m0.geom_dataid[gid]
    return gid, m0.mesh_vert[m0.mesh_vertadr[mid] : m0.mesh_vertadr[mid] + m0.mesh_vertnum[mid]]


def _mesh_to_box(geom, m0) -> None:
    """Edit 7: the hand's mesh becomes its bounding box in the mesh's own (inertial) frame."""
    import mujoco

    gid, v = _mesh_vertices(m0, geom.name)
    lo, hi = v.min(0), v.max(0)
    geom.type = mujoco.mjtGeom.mjGEOM_BOX
    geom.meshname = ""
    geom.size = np.round((hi - lo) / 2, 6)
    geom.pos = np.round(m0.geom_pos[gid] + _quat_to_mat(m0.geom_quat[gid]) @ ((hi + lo) / 2), 6)
    geom.quat = np.round(m0.geom_quat[gid], 6)


def _can_to_prism(spec, geom, m0) -> None:
    """Edit 5: the 2868-vertex can mesh becomes a 16-sided prism around it, in the body frame."""
    gid, v = _mesh_vertices(m0, geom.name)
    vb = v @ _quat_to_mat(m0.geom_quat[gid]).T + m0.geom_pos[gid]  # vertices in the body frame
    cxy = (vb[:, :2].max(0) + vb[:, :2].min(0)) / 2
    radius = float(np.sqrt(((vb[:, :2] - cxy) ** 2).sum(-1)).max())
    spec.add_mesh(name="Can_prism", uservert=_prism_vertices(radius, vb[:, 2].min(), vb[:, 2].max(), cxy).ravel())
    geom.meshname = "Can_prism"
    geom.pos = np.zeros(3)
    geom.quat = np.array([1.0, 0, 0, 0])


def _relocate_meshes(spec, task: str) -> None:
    """Edit 6 (mesh files under assets/, relative to envs/); unused meshes, materials and textures go (edit 2)."""
    import mujoco

    assets = str(robosuite_assets()) + "/"
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
