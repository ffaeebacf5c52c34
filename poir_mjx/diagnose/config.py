"""What ``diagnose`` takes apart: a typed, frozen config (the command line's fields)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from poir_mjx.core.config import ConfigError
from poir_mjx.envs.tasks import TASKS
from poir_mjx.eval.methods import METHODS

SOURCE = "diagnose"  # how errors name the command line's fields


@dataclasses.dataclass(frozen=True)
class DiagnoseConfig:
    """Planner forensics on the states a sweep cell's episodes visit (re-run in robosuite with the cell's keys)."""

    run: Path
    """The sweep's run folder, results/<name>/ (its config.json says the grid, seeds and checkpoints)."""
    task: str = "lift"
    """A task of the run."""
    method: str = "POIR-DRIL"
    """A planner method of the run (POIR-*): it drives the episodes, and its planner is taken apart."""
    sigma_init: tuple[float, ...] = (0.02, 0.3)
    """The cells' initial arm-joint noise: values among the run's sigma_init (action noise: the run's first)."""
    seed: int = 0
    """A seed of the run (the agent's training seed and the cells' episode keys)."""
    episodes: tuple[int, ...] = (0, 1)
    """Episode indices within each cell (0 .. the run's episodes - 1)."""
    every: int = 25
    """Take the planner apart every this many control steps of an episode (step 0 included)."""
    steps: int = 0
    """Control steps per episode at most; 0: the run's max_steps (an episode stops at its success)."""
    oracle: bool = True
    """Roll every candidate action sequence out in robosuite from the same state (the oracle check)."""
    holdout: float = 0.0
    """If > 0: also train a world model (same config and seed) on all but this fraction of the demos (the last
    ones, whole demos) and measure its one-step error on the held-out demos beside its training demos."""
    out: Path | None = None
    """Where the records and the page go; default results/diagnose/<run name>/."""
    checkpoints: Path = Path("checkpoints")
    """Where the sweep's checkpoints are (the sweep's --checkpoints)."""
    data: Path = Path("data/demos")
    """Where the sweep's demos are (read for the world model's error on them)."""
    progress: bool = True
    """Progress bars on stderr."""


def check(cfg: DiagnoseConfig) -> None:
    """Reject bad fields with one line naming the field (values that need the run are checked against it later)."""
    if cfg.task not in TASKS:
        raise ConfigError(f"{SOURCE}: field 'task': unknown task {cfg.task!r}; expected one of {', '.join(TASKS)}")
    m = METHODS.get(cfg.method)
    if m is None or m.act != "plan" or m.online:
        planners = [n for n, x in METHODS.items() if x.act == "plan" and not x.online]
        raise ConfigError(f"{SOURCE}: field 'method': {cfg.method!r} is not an offline planner method; expected one "
                          f"of {', '.join(planners)}")  # fmt: skip
    if not cfg.sigma_init or any(not (math.isfinite(v) and 0 <= v <= 10) for v in cfg.sigma_init):
        raise ConfigError(f"{SOURCE}: field 'sigma_init' must list values in [0, 10], got {list(cfg.sigma_init)}")
    if not cfg.episodes or any(not 0 <= e < 1_000_000 for e in cfg.episodes) or len(set(cfg.episodes)) < len(cfg.episodes):
        raise ConfigError(f"{SOURCE}: field 'episodes' must list distinct episode indices >= 0, got {list(cfg.episodes)}")
    if not 1 <= cfg.every <= 100_000:
        raise ConfigError(f"{SOURCE}: field 'every' must be in 1..100000, got {cfg.every}")
    if not 0 <= cfg.steps <= 100_000:
        raise ConfigError(f"{SOURCE}: field 'steps' must be in 0..100000 (0: the run's max_steps), got {cfg.steps}")
    if not (math.isfinite(cfg.holdout) and 0 <= cfg.holdout < 1):
        raise ConfigError(f"{SOURCE}: field 'holdout' must be in [0, 1), got {cfg.holdout}")
    if not 0 <= cfg.seed < 2**32:
        raise ConfigError(f"{SOURCE}: field 'seed' must be in 0..2**32-1, got {cfg.seed}")


def default_out(cfg: DiagnoseConfig) -> Path:
    return Path("results/diagnose") / Path(cfg.run).resolve().name


def require_robosuite() -> None:
    """The command line's check before any work: the forensics re-run episodes in robosuite."""
    from poir_mjx.optional import require_robosuite as require

    require("diagnose (episodes and the oracle run in robosuite)")
