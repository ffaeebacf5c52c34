"""What ``make video`` renders: a typed, frozen config (the command line's fields)."""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

from poir_mjx.core.config import ConfigError
from poir_mjx.envs.tasks import TASKS
from poir_mjx.eval.methods import METHODS
from poir_mjx.typed_config import NOISE, SEED

SOURCE = "video"  # how errors name the command line's fields


@dataclasses.dataclass(frozen=True)
class VideoConfig:
    """Episodes of one sweep cell re-run in MJX and drawn offscreen to an MP4 (one frame per control step)."""

    ZERO_OK = ("episodes", "seed", "steps")
    BOUNDS = {"seed": SEED, "sigma_init": NOISE, "sigma_action": NOISE, "episodes": (0, 10**6), "steps": (0, 10**6),
              "fps": (1, 1000)}

    run: Path
    """The sweep's run folder, results/<name>/ (its config.json says the grid, seeds and checkpoints)."""
    task: str = "lift"
    """A task of the run."""
    method: str = "POIR-DRIL"
    """A method of the run (offline methods: BC, EBC, POIR-*)."""
    versus: str | None = None
    """A second method of the run, drawn to the right of the first on the same episodes (same starting states)."""
    sigma_init: float = 0.02
    """The cell's initial arm-joint noise: one of the run's sigma_init."""
    sigma_action: float = 0.0
    """The cell's action noise: one of the run's sigma_action."""
    episodes: tuple[int, ...] = (0,)
    """Episode indices within the cell (0 .. the run's episodes - 1): the cell's episode keys, one after another
    (an MJX run's episodes themselves; a robosuite run drew its own starting states from these keys)."""
    seed: int = 0
    """A seed of the run (the agent's training seed and the cell's episode keys)."""
    steps: int = 0
    """Control steps per episode; 0: the run's max_steps."""
    width: int = 320
    """Frame width in pixels for each method (even)."""
    height: int = 240
    """Frame height in pixels (even)."""
    fps: int = 20
    """Frames per second; one frame per control step, so 20 is real time (robosuite's control rate)."""
    camera: str = "three_quarter"
    """Camera: three_quarter, close (added for videos), or robosuite's frontview, agentview, sideview, birdview."""
    out: Path | None = None
    """Where the MP4 goes; default results/videos/<run>-<task>-<method>[-vs-<versus>]-si<>-sa<>-ep<>.mp4."""
    checkpoints: Path = Path("checkpoints")
    """Where the sweep's checkpoints are (the sweep's --checkpoints)."""
    data: Path = Path("data/demos")
    """Where the sweep's demos are (read only if a checkpoint has to be trained again)."""

    def outputs(self):
        """The MP4 (poir_mjx/outputs.py checks it before any work); demos or a checkpoint made again go to
        --data and --checkpoints."""
        return [(self.out if self.out is not None else default_out(self), "file", "--out"),
                (self.checkpoints, "folder", "--checkpoints"), (self.data, "folder", "--data")]


def check(cfg: VideoConfig) -> None:
    """Reject bad fields with one line naming the field (values that need the run are checked against it later)."""
    if cfg.task not in TASKS:
        raise ConfigError(f"{SOURCE}: field 'task': unknown task {cfg.task!r}; expected one of {', '.join(TASKS)}")
    for field in ("method", "versus"):
        m = getattr(cfg, field)
        if (m is not None or field == "method") and m not in METHODS:
            raise ConfigError(f"{SOURCE}: field '{field}': unknown method {m!r}; expected one of {', '.join(METHODS)}")
    for field in ("sigma_init", "sigma_action"):
        v = getattr(cfg, field)
        if not (math.isfinite(v) and v >= 0):
            raise ConfigError(f"{SOURCE}: field '{field}' must be finite and >= 0, got {v}")
    if not cfg.episodes or any(e < 0 for e in cfg.episodes):
        raise ConfigError(f"{SOURCE}: field 'episodes' must list episode indices >= 0, got {list(cfg.episodes)}")
    for field in ("width", "height"):
        v = getattr(cfg, field)
        if not (2 <= v <= 4096 and v % 2 == 0):
            raise ConfigError(f"{SOURCE}: field '{field}' must be an even number of pixels in 2..4096, got {v}")
    if cfg.fps <= 0:
        raise ConfigError(f"{SOURCE}: field 'fps' must be positive, got {cfg.fps}")
    if cfg.steps < 0:
        raise ConfigError(f"{SOURCE}: field 'steps' must be positive (or 0: the run's max_steps), got {cfg.steps}")
    if cfg.out is not None and cfg.out.suffix.lower() != ".mp4":
        raise ConfigError(f"{SOURCE}: field 'out' must name an .mp4 file, got {cfg.out}")


def default_out(cfg: VideoConfig) -> Path:
    """results/videos/<run>-<task>-<method>[-vs-<versus>]-si<>-sa<>-ep<i>[_<j>...].mp4"""
    methods = cfg.method + (f"-vs-{cfg.versus}" if cfg.versus else "")
    name = (f"{Path(cfg.run).resolve().name}-{cfg.task}-{methods}-si{cfg.sigma_init:g}-sa{cfg.sigma_action:g}"
            f"-ep{'_'.join(map(str, cfg.episodes))}.mp4")  # fmt: skip
    return Path("results/videos") / re.sub(r"[^A-Za-z0-9._-]+", "_", name)
