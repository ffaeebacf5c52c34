"""Offscreen frames of recorded states: MuJoCo's renderer (EGL or OSMesa, no display), captions with Pillow.

MuJoCo picks its OpenGL backend from ``MUJOCO_GL`` when it is first imported; ``poir_mjx.video``
sets ``MUJOCO_GL=egl`` on Linux unless it is set already. A machine without the library gets
``MissingDependencyError`` with one line saying what to install.
"""

from __future__ import annotations

import contextlib
import gc
import os
import sys
import warnings
from typing import Iterator

import numpy as np

from poir_mjx.optional import MissingDependencyError

GL_HINT = ("offscreen rendering needs EGL (Debian/Ubuntu: apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri; "
           "MUJOCO_GL=egl) or OSMesa (apt-get install libosmesa6; MUJOCO_GL=osmesa), chosen before mujoco "
           "is first imported")  # fmt: skip


def gl_error(e: BaseException) -> MissingDependencyError:
    backend = os.environ.get("MUJOCO_GL", "")
    return MissingDependencyError(f"MuJoCo's renderer with MUJOCO_GL={backend!r} failed "
                                  f"({type(e).__name__}: {e}); {GL_HINT}")  # fmt: skip


@contextlib.contextmanager
def _quiet():
    """Silence what a failing backend prints besides its exception (GLFW's warnings, a half-built
    Renderer's complaint when it is collected): the one-line error says it all."""
    hook = sys.unraisablehook
    sys.unraisablehook = lambda unraisable: None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield
            gc.collect()
    finally:
        sys.unraisablehook = hook


def import_mujoco():
    """mujoco, imported with its OpenGL backend (a missing library fails here for osmesa)."""
    try:
        with _quiet():
            import mujoco
    except Exception as e:  # RuntimeError (unknown MUJOCO_GL), ImportError / AttributeError (library missing)
        raise gl_error(e) from None
    return mujoco


@contextlib.contextmanager
def renderer(model, width: int, height: int) -> Iterator:
    """A ``mujoco.Renderer`` for `model` at width x height, closed on exit."""
    mujoco = import_mujoco()
    vis = model.vis.global_
    vis.offwidth, vis.offheight = max(vis.offwidth, width), max(vis.offheight, height)
    err = None
    with _quiet():
        try:
            r = mujoco.Renderer(model, height, width)
        except Exception as e:  # no EGL/OSMesa library or no device: one line, not a traceback
            err = gl_error(e)
    if err is not None:
        raise err
    try:
        yield r
    finally:
        r.close()


def check_gl() -> None:
    """Draw one tiny frame, so that a machine without EGL/OSMesa hears it at once (one line), not after compiling."""
    mujoco = import_mujoco()
    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='0.1'/></worldbody></mujoco>")
    with renderer(model, 4, 4) as r:
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        r.update_scene(data)
        try:
            r.render()
        except Exception as e:
            raise gl_error(e) from None


def camera_names(model) -> list[str]:
    mujoco = import_mujoco()
    return [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_CAMERA, i) for i in range(model.ncam)]


def check_camera(task: str, camera: str) -> None:
    from poir_mjx.core.config import ConfigError
    from poir_mjx.video.scene import scene_model

    names = camera_names(scene_model(task))
    if camera not in names:
        raise ConfigError(f"video: field 'camera': {task} has no camera {camera!r}; expected one of {', '.join(names)}")


class Painter:
    """Draws qpos vectors of one model from one camera: ``frame(qpos)`` -> uint8 [H, W, 3]."""

    def __init__(self, r, model, camera: str):
        mujoco = import_mujoco()
        if camera not in camera_names(model):
            names = ", ".join(camera_names(model))
            raise ValueError(f"camera: the model has no camera {camera!r}; expected one of {names}")
        self.r, self.model, self.camera = r, model, camera
        self.data = mujoco.MjData(model)
        self._mujoco = mujoco

    def pose(self, qpos: np.ndarray) -> None:
        self.data.qpos[:] = qpos
        self._mujoco.mj_forward(self.model, self.data)
        self.r.update_scene(self.data, camera=self.camera)

    def frame(self, qpos: np.ndarray) -> np.ndarray:
        self.pose(qpos)
        return self.r.render().copy()

    def segmentation(self, qpos: np.ndarray) -> np.ndarray:
        """[H, W] id of the geom seen at each pixel (-1: background)."""
        self.pose(qpos)
        self.r.enable_segmentation_rendering()
        try:
            seg = self.r.render().copy()
        finally:
            self.r.disable_segmentation_rendering()
        return np.where(seg[..., 1] == int(self._mujoco.mjtObj.mjOBJ_GEOM), seg[..., 0], -1)


def caption(frame: np.ndarray, lines: list[str]) -> np.ndarray:
    """`frame` with `lines` written in its top-left corner (white on a dark band)."""
    from PIL import Image, ImageDraw, ImageFont

    h = frame.shape[0]
    size = max(8, h // 22)
    try:
        font = ImageFont.load_default(size=size)
    except TypeError:  # Pillow without FreeType: the fixed bitmap font
        font = ImageFont.load_default()
    img = Image.fromarray(frame)
    draw = ImageDraw.Draw(img)
    pad = max(1, size // 4)
    band = len(lines) * (size + pad) + pad
    draw.rectangle([0, 0, frame.shape[1], band], fill=(20, 20, 24))
    for i, text in enumerate(lines):
        draw.text((pad * 2, pad + i * (size + pad)), text, fill=(255, 255, 255), font=font)
    return np.asarray(img)
