"""Episode videos (``make video``): a sweep cell's episodes re-run in MJX, drawn offscreen, written to an MP4.

``render_video(VideoConfig(run=Path("results/cpu-small"), method="EBC", versus="POIR-DRIL", sigma_init=0.4))``.
Files by idea: ``config.py`` (what to render), ``record.py`` (the states, from the one episode rollout),
``scene.py`` (the model a picture is drawn with), ``render.py`` (offscreen frames), ``encode.py`` (MP4),
``video.py`` (the pieces together).

MuJoCo chooses its OpenGL backend when it is first imported: on Linux this package sets
``MUJOCO_GL=egl`` (headless) unless it is set, so import it before mujoco or set the variable yourself. It does so
only where libEGL can be found: with ``egl`` and no libEGL, ``import mujoco`` itself fails (PyOpenGL raises
AttributeError, which mujoco does not catch), so every command, not only ``video``, would stop.
"""

import ctypes.util
import os
import sys

if sys.platform.startswith("linux") and ctypes.util.find_library("EGL"):
    os.environ.setdefault("MUJOCO_GL", "egl")

from poir_mjx.video.config import VideoConfig  # noqa: E402

__all__ = ["VideoConfig", "render_video"]


def __getattr__(name):  # render_video imported on first use: building the command line stays light
    if name == "render_video":
        from poir_mjx.video.video import render_video

        return render_video
    raise AttributeError(name)
