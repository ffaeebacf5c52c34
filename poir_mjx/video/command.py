"""``python -m poir_mjx.cli video ...`` (make video; the command line checks OpenGL first): render, say where."""

from __future__ import annotations

from pathlib import Path

from poir_mjx.video.config import VideoConfig


def run(cfg: VideoConfig) -> int:
    from poir_mjx.video.video import render_video

    path = render_video(cfg)
    print(f"wrote {path} ({Path(path).stat().st_size / 1e6:.2f} MB)")
    return 0
