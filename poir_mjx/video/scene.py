"""The model a video is drawn with: the task's exported model plus visual-only geoms.

The exported models keep only what collides (envs/README.md, edits 2-3): no arm-link geoms, no
textures. For a picture, each Panda link is drawn as a capsule from its joint frame to the next one
(spheres at the joints), the mount as a pedestal, the table with legs, in flat colours. The added
geoms collide with nothing and add no joint, so the model's qpos layout is the task's own: a
recorded qpos is drawn as is. Lift's cube is compiled at the episode's size variant.
"""

from __future__ import annotations

import mujoco
import numpy as np

from poir_mjx.cached import builder
from poir_mjx.envs.env import load_model
from poir_mjx.envs.tasks import task_files
from poir_mjx.envs.variants import NUM_VARIANTS, variant_sizes

# Names of the geoms added for the picture start with this (the tests find the arm's pixels by it).
PREFIX = "video_"
ARM_LINKS = tuple(f"robot0_link{i}" for i in range(8))
ARM_COLOUR = (0.92, 0.92, 0.94, 1.0)
JOINT_COLOUR = (0.25, 0.25, 0.28, 1.0)
# Cameras added for videos, (eye, target) in world coordinates: the robot's base is at x = -0.56, the
# table's top at z = 0.8; "three_quarter" (the default) sees the arm and the object from the front right.
CAMERAS = {"three_quarter": ((0.85, -1.3, 1.8), (-0.25, 0.0, 1.08)), "close": ((0.45, -0.6, 1.2), (-0.05, 0.0, 0.88))}
# Flat colours for the exported geoms, by name prefix.
RECOLOUR = {"floor": (0.35, 0.37, 0.40, 1.0), "table": (0.72, 0.56, 0.38, 1.0), "gripper0": (0.2, 0.2, 0.22, 1.0),
            "cube": (0.85, 0.12, 0.12, 1.0)}  # fmt: skip


def _visual(body, name: str, gtype, rgba, size=None, fromto=None, pos=None):
    g = body.add_geom()
    g.name = PREFIX + name
    g.type = gtype
    g.contype = g.conaffinity = 0
    g.mass = 0.0
    g.rgba = rgba
    if fromto is not None:
        g.fromto = fromto
    if pos is not None:
        g.pos = pos
    if size is not None:
        g.size = size
    return g


def decorate(spec: mujoco.MjSpec) -> mujoco.MjSpec:
    """Add the visual geoms to an exported task's spec (in place) and recolour its geoms."""
    cap, sph = mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_SPHERE
    chain = [spec.body(n) for n in ARM_LINKS] + [spec.body("robot0_right_hand")]
    for i, (body, child) in enumerate(zip(chain[:-1], chain[1:])):
        radius = 0.06 if i < 4 else 0.045
        end = np.asarray(child.pos, np.float64)
        if np.linalg.norm(end) > 1e-6:
            _visual(body, f"{ARM_LINKS[i]}_link", cap, ARM_COLOUR, size=[radius, 0, 0], fromto=[0, 0, 0, *end])
        _visual(body, f"{ARM_LINKS[i]}_joint", sph, JOINT_COLOUR if i else ARM_COLOUR, size=[radius * 1.1, 0, 0])
    # The wrist flange up to the hand: link7's frame to the hand's.
    _visual(chain[-1], "robot0_link7_flange", mujoco.mjtGeom.mjGEOM_CYLINDER, ARM_COLOUR, size=[0.04, 0.02, 0],
            pos=[0, 0, -0.02])  # fmt: skip
    base = spec.body("robot0_base")
    cyl = mujoco.mjtGeom.mjGEOM_CYLINDER
    _visual(base, "mount_pedestal", cyl, JOINT_COLOUR, size=[0.1, 0.45, 0], pos=[0, 0, -0.46])
    table = spec.body("table")
    top = next((g for g in spec.geoms if g.name.startswith("table")), None)
    if top is not None:
        hx, hy, hz = top.size[:3]
        height = float(table.pos[2]) - hz
        for sx in (-1, 1):
            for sy in (-1, 1):
                leg = [sx * (hx - 0.05), sy * (hy - 0.05), -hz - height / 2]
                _visual(table, f"table_leg_{sx}_{sy}", mujoco.mjtGeom.mjGEOM_BOX, RECOLOUR["table"],
                        size=[0.025, 0.025, height / 2], pos=leg)  # fmt: skip
    for name, (eye, target) in CAMERAS.items():
        cam = spec.worldbody.add_camera()
        cam.name = name
        cam.pos = eye
        fwd = np.subtract(target, eye) / np.linalg.norm(np.subtract(target, eye))
        right = np.cross(fwd, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        cam.alt.type = mujoco.mjtOrientation.mjORIENTATION_XYAXES
        cam.alt.xyaxes = [*right, *np.cross(right, fwd)]
    sky = spec.add_texture()
    sky.name, sky.type = PREFIX + "sky", mujoco.mjtTexture.mjTEXTURE_SKYBOX
    sky.builtin = mujoco.mjtBuiltin.mjBUILTIN_GRADIENT
    sky.rgb1, sky.rgb2, sky.width, sky.height = [0.55, 0.65, 0.75], [0.1, 0.1, 0.12], 64, 384
    for g in spec.geoms:
        for prefix, rgba in RECOLOUR.items():
            if g.name.startswith(prefix):
                g.rgba = rgba
    return spec


@builder
def scene_model(task: str, variant: int = 0) -> mujoco.MjModel:
    """The task's model for pictures, with object-size variant `variant` (``info["variant"]``; Lift only)."""
    files = task_files(task)
    mj_model, meta = load_model(task)
    spec = mujoco.MjSpec.from_string(files.xml.read_text())
    spec.meshdir = str(files.xml.parent.resolve()) + "/"
    decorate(spec)
    if "object_size" in meta:
        gid = mujoco.mj_name2id(mj_model, mujoco.mjtObj.mjOBJ_GEOM, meta["object_size"]["geom"])
        sizes = variant_sizes(meta, mj_model.geom_size[gid], NUM_VARIANTS)
        if not 0 <= variant < len(sizes):
            raise ValueError(f"variant: {task} has {len(sizes)} object-size variants, got {variant}")
        spec.geom(meta["object_size"]["geom"]).size[:3] = sizes[variant]
    elif variant != 0:
        raise ValueError(f"variant: {task} has one model, got variant {variant}")
    model = spec.compile()
    if model.nq != mj_model.nq:  # the picture must read the rollout's qpos as is
        raise AssertionError(f"{task}: the video model has nq {model.nq}, the task {mj_model.nq}")
    return model


def arm_geoms(model: mujoco.MjModel) -> np.ndarray:
    """Ids of the geoms drawing the arm's links and joints (the picture's Panda)."""
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in range(model.ngeom)]
    return np.array([g for g, n in enumerate(names) if n.startswith(PREFIX + "robot0_")], np.int32)
