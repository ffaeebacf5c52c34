"""What ``diagnose`` takes apart: a typed, frozen config (the command line's fields)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from poir_mjx import typed_config
from poir_mjx.core.config import ConfigError
from poir_mjx.typed_config import NOISE, SEED
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

    ZERO_OK = ("sigma_init", "seed", "episodes", "steps", "holdout")
    OPEN_UNIT = ("holdout",)
    BOUNDS = {"sigma_init": NOISE, "seed": SEED, "episodes": (0, 10**6), "every": (1, 10**5), "steps": (0, 10**5)}

    def outputs(self):
        """The records and the page (poir_mjx/outputs.py checks them before any work); demos or a checkpoint made
        again go to --data and --checkpoints."""
        return [(self.out if self.out is not None else default_out(self), "folder", "--out"),
                (self.checkpoints, "folder", "--checkpoints"), (self.data, "folder", "--data")]


def check(cfg: DiagnoseConfig) -> None:
    """Reject bad fields with one line naming the field (values that need the run are checked against it later)."""
    typed_config.check(cfg, f"{SOURCE}: ")
    if cfg.task not in TASKS:
        raise ConfigError(f"{SOURCE}: field 'task': unknown task {cfg.task!r}; expected one of {', '.join(TASKS)}")
    m = METHODS.get(cfg.method)
    if m is None or m.act != "plan" or m.online:
        planners = [n for n, x in METHODS.items() if x.act == "plan" and not x.online]
        raise ConfigError(f"{SOURCE}: field 'method': {cfg.method!r} is not an offline planner method; expected one "
                          f"of {', '.join(planners)}")  # fmt: skip


def default_out(cfg: DiagnoseConfig) -> Path:
    return Path("results/diagnose") / Path(cfg.run).resolve().name


def require_robosuite() -> None:
    """The command line's check before any work: the forensics re-run episodes in robosuite."""
    from poir_mjx.optional import require_robosuite as require

    require("diagnose (episodes and the oracle run in robosuite)")
