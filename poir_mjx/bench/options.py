"""The options of the ``bench`` subcommands (make bench-*): one frozen dataclass each, its field docstrings the help."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Literal, Optional

from poir_mjx.core.config import PRESETS, REWARDS
from poir_mjx.envs.physics import PhysicsPresetName
from poir_mjx.envs.tasks import DEFAULT_NUM_DEMOS, TASKS
from poir_mjx.outputs import file_pair
from poir_mjx.typed_config import NOISE

Task = Literal[TASKS]  # type: ignore[valid-type]
Preset = Literal[tuple(PRESETS)]  # type: ignore[valid-type]
Reward = Literal[REWARDS]  # type: ignore[valid-type]


@dataclasses.dataclass(frozen=True)
class BenchEnv:
    """MJX vs robosuite control-step throughput (make bench-env) -> <out>/<name>.{json,md}."""

    BOUNDS = {"batch_sizes": (1, 2**20), "steps": (1, 10**6), "robosuite_steps": (1, 10**7)}

    out: Path = Path("results/bench")
    """Output folder."""
    tasks: tuple[Task, ...] = TASKS  # type: ignore[valid-type]
    """Tasks to time."""
    batch_sizes: tuple[int, ...] = (1, 16, 64, 256)
    """MJX batch sizes."""
    contact_rich_batch_sizes: Optional[tuple[int, ...]] = None
    """Batch sizes for PickPlaceCan and NutAssemblySquare (default: --batch-sizes)."""
    steps: int = 5
    """Timed MJX control steps per batch size."""
    robosuite_steps: int = 100
    """Timed robosuite control steps (where robosuite is installed)."""
    name: str = "env"
    """Output file name without extension."""

    def outputs(self):
        return [(self.out, "folder", "--out"), (self.name, "name", "--name"), *file_pair(self.out, self.name, "--name")]


@dataclasses.dataclass(frozen=True)
class BenchPhysics:
    """MJX physics presets side by side (make bench-env): ms per physics substep, and the error against robosuite
    on the fidelity test's grasp-and-lift replay -> <out>/<name>.{json,md}."""

    BOUNDS = {"batch_sizes": (1, 2**20), "contact_rich_batch_sizes": (1, 2**20), "steps": (1, 10**6),
              "rounds": (1, 1000)}  # fmt: skip

    out: Path = Path("results/bench")
    """Output folder."""
    tasks: tuple[Task, ...] = TASKS  # type: ignore[valid-type]
    """Tasks to time."""
    physics: tuple[PhysicsPresetName, ...] = ("reference", "fast")
    """Physics presets (poir_mjx/envs/physics.py), each timed at every batch size."""
    batch_sizes: tuple[int, ...] = (1, 16, 64)
    """MJX batch sizes for Lift."""
    contact_rich_batch_sizes: Optional[tuple[int, ...]] = (1, 16)
    """Batch sizes for PickPlaceCan and NutAssemblySquare (None: --batch-sizes)."""
    steps: int = 2
    """Timed control steps per round (after the one that compiles)."""
    rounds: int = 3
    """Rounds per batch size, the presets timed in alternation (the fastest round counts)."""
    fidelity: bool = True
    """Also replay robosuite's grasp-and-lift script under each preset (needs robosuite; skipped without it)."""
    name: str = "physics"
    """Output file name without extension."""

    def outputs(self):
        return [(self.out, "folder", "--out"), (self.name, "name", "--name"), *file_pair(self.out, self.name, "--name")]


@dataclasses.dataclass(frozen=True)
class BenchPlanner:
    """POIR planner calls per second (make bench-planner) -> <out>/planner.{json,md}."""

    BOUNDS = {"batch_sizes": (1, 2**20), "calls": (1, 10**6), "expert_states": (1, 10**7)}

    out: Path = Path("results/bench")
    """Output folder."""
    presets: tuple[Preset, ...] = ("cpu-small", "paper")  # type: ignore[valid-type]
    """Presets to time."""
    rewards: tuple[Reward, ...] = REWARDS  # type: ignore[valid-type]
    """Imitation rewards to time."""
    batch_sizes: tuple[int, ...] = (1, 16)
    """Episodes per planner call."""
    paper_batch_sizes: Optional[tuple[int, ...]] = None
    """Batch sizes for the paper preset (default: --batch-sizes)."""
    calls: int = 5
    """Timed calls per row."""
    expert_states: int = 30000
    """Expert states the L2 reward searches."""

    def outputs(self):
        return [(self.out, "folder", "--out"), *file_pair(self.out, "planner", "--out")]


@dataclasses.dataclass(frozen=True)
class BenchE2E:
    """Evaluated episodes per minute on Lift, per preset and method (make bench-e2e) -> <out>/e2e.{json,md}."""

    ZERO_OK = ("demo_batch",)
    BOUNDS = {"episodes": (1, 2**20), "steps": (1, 10**6), "num_demos": (1, 10**6), "demo_batch": (0, 2**16)}

    out: Path = Path("results/bench")
    """Output folder."""
    presets: tuple[Preset, ...] = ("cpu-small",)  # type: ignore[valid-type]
    """Presets to time."""
    methods: tuple[str, ...] = ("EBC", "POIR-DRIL")
    """Methods from the registry."""
    episodes: int = 16
    """Episodes per batch."""
    steps: int = 100
    """Control steps per episode."""
    num_demos: int = DEFAULT_NUM_DEMOS
    """Scripted-expert demonstrations to train on."""
    demo_simulator: Literal["auto", "robosuite", "mjx"] = "auto"
    """Where the demos are recorded: "auto" (robosuite where installed, else MJX), "robosuite" or "mjx"."""
    demo_batch: int = 0
    """MJX demo episodes per compiled batch (0: 256 on an accelerator, 16 on a CPU)."""

    def outputs(self):
        return [(self.out, "folder", "--out"), *file_pair(self.out, "e2e", "--out")]


@dataclasses.dataclass(frozen=True)
class BenchRobosuite:
    """Episodes in robosuite: bare stepping vs EBC and POIR-DRIL collection, plain and overlapped
    (make bench-robosuite) -> <out>/robosuite-e2e.{json,md}, each row written as it finishes."""

    ZERO_OK = ("workers",)
    BOUNDS = {"episodes": (1, 2**20), "steps": (1, 10**6), "workers": (0, 1024), "sigma_init": NOISE}

    out: Path = Path("results/bench")
    """Output folder."""
    task: Task = "lift"  # type: ignore[valid-type]
    """Task to step."""
    methods: tuple[str, ...] = ("EBC", "POIR-DRIL")
    """Methods from the registry (their cpu-small agents, trained on first use from the scripted demos)."""
    episodes: int = 16
    """Episodes per timed batch."""
    steps: int = 200
    """Control steps per episode (episodes that succeed stop earlier: the rate counts steps taken)."""
    workers: int = 0
    """robosuite worker processes (0: one per CPU core)."""
    sigma_init: float = 0.3
    """Initial arm-joint noise (high enough that episodes run long)."""

    def outputs(self):
        return [(self.out, "folder", "--out"), *file_pair(self.out, "robosuite-e2e", "--out")]


@dataclasses.dataclass(frozen=True)
class RunStates:
    """What a bench on a sweep run's agent reads (bench precision, bench l2): the run, a task and seed of it, the
    states its cells' episodes visit in robosuite and demo states."""

    ZERO_OK = ("seed", "demo_states")
    BOUNDS = {"sigma_init": NOISE, "episodes": (1, 10**4), "every": (1, 10**4), "demo_states": (0, 10**5),
              "seed": (0, 2**31 - 1), "steps": (1, 10**5)}  # fmt: skip

    run: Path = Path("results/cpu-prior")
    """The sweep's run folder (its config.json names the grid, seeds and checkpoints)."""
    task: Task = "lift"  # type: ignore[valid-type]
    """A task of the run."""
    sigma_init: tuple[float, ...] = (0.02, 0.3)
    """Initial arm-joint noise of the episodes whose states are taken (the run's episode keys for that level)."""
    episodes: int = 2
    """Episodes per noise level (the first of the run's keys at that level)."""
    every: int = 10
    """A state every this many control steps."""
    steps: int = 200
    """Control steps per episode at most (it stops at its success)."""
    demo_states: int = 64
    """Demo states (the first of the L2 reward's expert states) also measured."""
    seed: int = 0
    """A seed of the run (its agents and episode keys)."""
    checkpoints: Path = Path("checkpoints")
    """Where the sweep's checkpoints are."""
    data: Path = Path("data/demos")
    """Where the sweep's demos are (read only if an agent must be trained again)."""
    out: Path = Path("results/bench")
    """Output folder."""

    def outputs(self):
        return [(self.out, "folder", "--out"), (self.name, "name", "--name"), *file_pair(self.out, self.name, "--name"),
                (self.checkpoints, "folder", "--checkpoints"), (self.data, "folder", "--data")]  # fmt: skip


@dataclasses.dataclass(frozen=True)
class BenchPrecision(RunStates):
    """The planner's decisions under each reduced matmul setting (PlannerConfig.matmul) against true float32, on a
    sweep run's agents: at the states its cells' episodes visit (robosuite, driven by the float32 planner) and at
    its demos' states, with the same keys -> <out>/<name>.{json,md}. Needs robosuite."""

    methods: tuple[str, ...] = ("POIR-DRIL", "POIR-MOREL")
    """Planner methods of the run (their agent: the run's checkpoint for the task and seed)."""
    matmul: tuple[Literal["tf32", "bfloat16"], ...] = ("tf32", "bfloat16")
    """Matmul settings compared with "float32"."""
    name: str = "precision-cpu"
    """Output file name without extension."""


@dataclasses.dataclass(frozen=True)
class BenchL2(RunStates):
    """The L2 reward's exact nearest-expert search, the full scan against the shortlist (PlannerConfig.l2_shortlist,
    core/nearest.py), in a sweep run's POIR-L2 planner at the states its cells' episodes visit (robosuite) and at
    demo states, batched as a sweep batches its episodes, side by side in one process -> <out>/<name>.{json,md}.
    Needs robosuite."""

    BOUNDS = {**RunStates.BOUNDS, "calls": (1, 10**4), "shortlist": (1, 10**7)}

    run: Path = Path("results/cpu-options-can-combined-seed1")
    """The sweep's run folder (its config.json names the grid, seeds and checkpoints)."""
    task: Task = "pick_place_can"  # type: ignore[valid-type]
    """A task of the run."""
    method: str = "POIR-L2"
    """A planner method of the run with the L2 reward."""
    shortlist: int = 2048
    """The shortlist timed against the full scan (l2_shortlist 0)."""
    calls: int = 3
    """Timed batched planner calls per state group and search."""
    name: str = "l2-search"
    """Output file name without extension."""
