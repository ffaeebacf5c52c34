"""A sweep worked out once: its grid, each method's config hash per task and every cell's record path,
and the one reader of its cell records (the sweep's loop, the tables and the learning curves use it)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Callable, Iterator

from poir_mjx.core.config import POIRConfig
from poir_mjx.eval.methods import get_method
from poir_mjx.sweep.artifacts import cell_hash, cell_path
from poir_mjx.sweep.records import read_cell
from poir_mjx.sweep.config import SweepConfig, base_config


@dataclasses.dataclass(frozen=True)
class Cell:
    """One (task, method, sigma_init, sigma_action, seed) of a sweep, its record's path and config hash."""

    task: str
    method: str
    sigma_init: float
    sigma_action: float
    seed: int
    path: Path
    config_hash: str
    episodes: int
    """The config's episodes per cell (a record of this config must have as many)."""

    def expect(self) -> dict:
        """What a record of this cell made with this config says (``records.read_cell`` checks it)."""
        return {"episodes": self.episodes, "task": self.task, "method": self.method, "seed": self.seed,
                "sigma_init": self.sigma_init, "sigma_action": self.sigma_action}

    def record(self) -> dict | None:
        """The cell's record if it exists and was made with this config (``read_cell`` checks its schema)."""
        return read_cell(self.path, self.config_hash, self.expect())


@dataclasses.dataclass(frozen=True)
class SweepPlan:
    cfg: SweepConfig
    out: Path
    """The run folder (results/<name>/)."""
    digests: dict[str, str]
    """Each task's expert-data content digest (``transitions_digest``), part of every cell's hash."""
    base: POIRConfig
    """The POIR config every method of the sweep starts from (preset, then the sweep's overrides)."""
    hashes: dict[tuple[str, str], str]
    """(task, method) -> the config hash its cells must carry."""

    @classmethod
    def build(cls, cfg: SweepConfig, out: Path, digests: dict[str, str]) -> SweepPlan:
        hashes = {(t, m): cell_hash(cfg, t, m, digests[t]) for t in cfg.tasks for m in cfg.methods}
        return cls(cfg, Path(out), dict(digests), base_config(cfg), hashes)

    @property
    def grid(self) -> list[tuple[float, float]]:
        """The noise cells (sigma_init, sigma_action), sigma_action varying fastest."""
        return [(si, sa) for si in self.cfg.sigma_init for sa in self.cfg.sigma_action]

    def cell(self, task: str, method: str, si: float, sa: float, seed: int) -> Cell:
        return Cell(task, method, si, sa, seed, cell_path(self.out, task, method, si, sa, seed),
                    self.hashes[(task, method)], self.cfg.episodes)  # fmt: skip

    def cells(self, task: str, method: str, seed: int) -> list[Cell]:
        """The grid's cells of (task, method, seed), in grid order (the order their episodes' keys follow)."""
        return [self.cell(task, method, si, sa, seed) for si, sa in self.grid]

    def runs(self) -> list[tuple[str, str, int]]:
        """(task, method, seed) in the order the sweep computes them."""
        return [(t, m, s) for t in self.cfg.tasks for m in self.cfg.methods for s in self.cfg.seeds]

    def results(self, task: str, which: Callable[[str], bool] = lambda m: True
                ) -> Iterator[tuple[str, float, float, list[dict]]]:  # fmt: skip
        """(method, sigma_init, sigma_action, records over the seeds) of every noise cell of `task` with at least
        one current record, methods in the config's order (those `which` accepts), then the grid's order."""
        for m in (m for m in self.cfg.methods if which(m)):
            for si, sa in self.grid:
                recs = [r for r in (self.cell(task, m, si, sa, s).record() for s in self.cfg.seeds) if r]
                if recs:
                    yield m, si, sa, recs

    def method_config(self, method: str) -> POIRConfig:
        """The POIR config `method` runs with (its reward, prior and online settings on the sweep's base)."""
        return get_method(method).agent_config(self.base)


def noise_label(si: float, sa: float, cfg: SweepConfig) -> str:
    """A noise cell as tables and curves name it."""
    return f"σ_init {si:g}" + (f", σ_act {sa:g}" if len(cfg.sigma_action) > 1 or sa else "")
