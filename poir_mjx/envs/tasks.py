"""The three robosuite tasks of the paper: names, robosuite construction arguments, files under envs/."""

from __future__ import annotations

import dataclasses
from pathlib import Path

TASKS = ("lift", "pick_place_can", "nut_assembly_square")
# Scripted-expert demonstrations per task unless a command or config says otherwise (robomimic's datasets hold 200
# per task); here, the lowest layer that needs it, so that options.py (no jax, no data/) can name it.
DEFAULT_NUM_DEMOS = 200

# robosuite class name for each task.
ROBOSUITE_ENV = {
    "lift": "Lift",
    "pick_place_can": "PickPlaceCan",
    "nut_assembly_square": "NutAssemblySquare",
}

# The object whose observables form robomimic's "object" key, and its robosuite body name.
OBJECT_BODY = {
    "lift": "cube_main",
    "pick_place_can": "Can_main",
    "nut_assembly_square": "SquareNut_main",
}

# A site on the part of the object a gripper closes on (used by scripted grasps).
GRASP_SITE = {
    "lift": "cube_default_site",
    "pick_place_can": "Can_default_site",
    "nut_assembly_square": "SquareNut_handle_site",
}
# How far beyond GRASP_SITE's centre along the object's x axis scripted grasps close (metres): on the
# nut, 8 mm further out along the handle, clear of the nut's wall.
GRASP_SITE_X_OFFSET = {"lift": None, "pick_place_can": None, "nut_assembly_square": 0.008}


def grasp_offset(task: str, model) -> tuple[float, float, float]:
    """The grasp point in the frame of the object's body (the body holding ``GRASP_SITE[task]``) of a MuJoCo
    model of the task: the body's origin, or a point GRASP_SITE_X_OFFSET beyond the site along x."""
    extra = GRASP_SITE_X_OFFSET[task]
    if extra is None:
        return (0.0, 0.0, 0.0)
    import mujoco

    site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, GRASP_SITE[task])
    return (float(model.site_pos[site][0]) + extra, 0.0, 0.0)

# Objects whose size robosuite redraws at every reset: Lift's BoxObject("cube", size_min, size_max)
# in robosuite/environments/manipulation/lift.py (half-sizes in metres, per axis).
OBJECT_SIZE_RANGE = {"lift": {"geom": "cube_g0", "size_min": [0.020, 0.020, 0.020], "size_max": [0.022, 0.022, 0.022]}}

CONTROL_FREQ = 20
HORIZON = 400
# Seed passed to robosuite when the model is built (Lift draws its cube size at build time).
EXPORT_SEED = 0

REPO_ROOT = Path(__file__).resolve().parents[2]
DEFAULT_ENVS_DIR = REPO_ROOT / "envs"
# Mesh files the exported models reference, copied from robosuite's models/assets/ (with its licence).
ASSETS_DIR = "assets"


class UnknownTaskError(ValueError):
    pass


def check_task(task: str) -> str:
    if task not in TASKS:
        raise UnknownTaskError(f"task: unknown task {task!r}; expected one of {', '.join(TASKS)}")
    return task


@dataclasses.dataclass(frozen=True)
class TaskFiles:
    xml: Path
    meta: Path


def task_files(task: str, envs_dir: Path | str | None = None) -> TaskFiles:
    d = Path(envs_dir) if envs_dir is not None else DEFAULT_ENVS_DIR
    check_task(task)
    return TaskFiles(xml=d / f"{task}.xml", meta=d / f"{task}.json")


def robosuite_kwargs(seed: int | None = EXPORT_SEED) -> dict:
    """robomimic's settings for the low-dim datasets: Panda, OSC_POSE (BASIC composite), 20 Hz, full physics."""
    from poir_mjx.optional import require_robosuite

    require_robosuite("building a robosuite environment")
    from robosuite.controllers import load_composite_controller_config

    return dict(
        robots="Panda",
        controller_configs=load_composite_controller_config(controller="BASIC", robot="Panda"),
        has_renderer=False,
        has_offscreen_renderer=False,
        use_camera_obs=False,
        use_object_obs=True,
        control_freq=CONTROL_FREQ,
        horizon=HORIZON,
        ignore_done=True,
        reward_shaping=False,
        lite_physics=False,
        seed=seed,
    )


def make_robosuite(task: str, seed: int | None = EXPORT_SEED, initialization_noise=None):
    """Build the robosuite environment for `task` (quietly)."""
    import logging

    import numpy as np

    check_task(task)
    from poir_mjx.optional import require_robosuite

    suite = require_robosuite("building a robosuite environment")

    # robosuite logs every unused controller part of its composite config as a warning.
    logging.getLogger("robosuite_logs").setLevel(logging.ERROR)
    if seed is not None:
        np.random.seed(seed)
    kwargs = robosuite_kwargs(seed)
    if initialization_noise is not None:
        kwargs["initialization_noise"] = initialization_noise
    return suite.make(ROBOSUITE_ENV[task], **kwargs)


def float32_square_note(tasks, simulators, x64: bool, remedy: str) -> str | None:
    """The note for a run where NutAssemblySquare steps in MJX in float32 (demos or evaluation), where the scripted
    expert's grasp fails in 12 of 32 episodes (32 of 32 in float64; docs/expert-data.md); None elsewhere."""
    if x64 or "mjx" not in simulators or "nut_assembly_square" not in tasks:
        return None
    return ("note: NutAssemblySquare in MJX runs in float32, where the scripted expert succeeds in 20 of 32 episodes "
            f"(32 of 32 in float64; docs/expert-data.md); {remedy} runs the physics in float64")  # fmt: skip
