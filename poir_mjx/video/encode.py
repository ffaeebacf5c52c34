"""MP4 files from frames, written atomically, with the ffmpeg that the imageio-ffmpeg wheel ships."""

from __future__ import annotations

import contextlib
import warnings
from pathlib import Path
from typing import Iterable

import numpy as np

from poir_mjx.atomic import atomic_path
from poir_mjx.optional import MissingDependencyError


def _ffmpeg():
    try:
        import imageio_ffmpeg
    except ImportError as e:
        raise MissingDependencyError(f"writing MP4 needs imageio-ffmpeg ({e}); pip install imageio-ffmpeg==0.8.1 "
                                     "(in requirements/cpu.txt and current.txt)") from None  # fmt: skip
    return imageio_ffmpeg


@contextlib.contextmanager
def _no_fork_warning():
    """JAX warns on any fork; subprocess forks only to exec ffmpeg at once, which is safe."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"os\.fork\(\) was called")
        yield


def write_mp4(path: str | Path, frames: Iterable[np.ndarray], fps: int) -> Path:
    """H.264 MP4 (yuv420p, plays everywhere) of uint8 [H, W, 3] frames of one even size; replaces `path` only
    once the file is complete. Returns `path`."""
    path = Path(path)
    it = iter(frames)
    first = np.asarray(next(it))
    h, w = first.shape[:2]
    if first.dtype != np.uint8 or first.ndim != 3 or first.shape[2] != 3 or h % 2 or w % 2:
        raise ValueError(f"frames: expected uint8 [H, W, 3] with even H and W, got {first.dtype} {first.shape}")
    with atomic_path(path) as tmp, _no_fork_warning():
        writer = _ffmpeg().write_frames(tmp, (w, h), fps=fps, codec="libx264", pix_fmt_out="yuv420p", quality=7,
                                        macro_block_size=2, ffmpeg_log_level="error",
                                        output_params=["-f", "mp4", "-movflags", "+faststart"])  # fmt: skip
        writer.send(None)
        try:
            writer.send(np.ascontiguousarray(first))
            for f in it:
                f = np.asarray(f)
                if f.shape != first.shape:
                    raise ValueError(f"frames: every frame must be {first.shape}, got {f.shape}")
                writer.send(np.ascontiguousarray(f))
        finally:
            writer.close()
    return path


def read_mp4(path: str | Path) -> np.ndarray:
    """All frames of a video as uint8 [T, H, W, 3] (for checks; videos here are small)."""
    with _no_fork_warning():
        gen = _ffmpeg().read_frames(str(path))
        meta = next(gen)
        w, h = meta["size"]
        frames = [np.frombuffer(b, np.uint8).reshape(h, w, 3) for b in gen]
    return np.stack(frames)
