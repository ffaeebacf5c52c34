"""``python -m poir_mjx.cli video ...`` (make video): check OpenGL first, then render and say where the MP4 went."""

from __future__ import annotations

from pathlib import Path

from poir_mjx.video.config import VideoConfig


def run(cfg: VideoConfig) -> int:
    from poir_mjx.video.render import check_gl
    from poir_mjx.video.video import render_video

    check_gl()  # mujoco's first import: a missing EGL/OSMesa fails here, before minutes of compilation
    path = render_video(cfg)
    print(f"wrote {path} ({Path(path).stat().st_size / 1e6:.2f} MB)")
    return 0
