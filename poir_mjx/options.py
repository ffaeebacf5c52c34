"""The options of each subcommand: one frozen dataclass per subcommand, its field docstrings the help text.

Only light imports here (no jax): the parser is built from these on every call, ``--help`` included.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Annotated, Literal, Optional

import tyro

from poir_mjx.flags import flags_type
from poir_mjx.core.config import PRESETS, REWARDS, PlannerConfig, POIRConfig
from poir_mjx.envs.physics import PhysicsPresetName
from poir_mjx.envs.tasks import DEFAULT_NUM_DEMOS, TASKS

Task = Literal[TASKS]  # type: ignore[valid-type]
Preset = Literal[tuple(PRESETS)]  # type: ignore[valid-type]
Reward = Literal[REWARDS]  # type: ignore[valid-type]

# Every POIR config field as a flag (--ensemble-size, --planner.sigma, --normalizer.clip, --online.num-envs, ...).
POIRFlags = flags_type(POIRConfig, "(default: the config file's)")
# The planner's fields for `eval` (the weights fix the rest; --method picks the reward and the prior).
PlannerFlags = flags_type(PlannerConfig, "(default: the checkpoint's)", exclude=("reward", "use_prior"))


@dataclasses.dataclass(frozen=True)
class Sweep:
    """Success rate versus noise over a grid (make sweep); the POIR flags override the config file's."""

    config: Path
    """Sweep config file (experiments/*.json)."""
    results: Path = Path("results")
    """Results folder: the run goes to <results>/<name>/."""
    data: Path = Path("data/demos")
    """Folder of the scripted expert's demonstrations (made on first use)."""
    checkpoints: Path = Path("checkpoints")
    """Folder of the trained agents (reused when config and data match)."""
    replace_config: bool = False
    """Run a changed config in an existing run folder (cells made with other settings are recomputed)."""
    poir: Annotated[POIRFlags, tyro.conf.arg(name="", prefix_name=False)] = POIRFlags()  # type: ignore[valid-type]
    """POIR config fields, added to the file's "overrides" (a flag wins over the file)."""


@dataclasses.dataclass(frozen=True)
class Eval:
    """Evaluate one checkpoint on a noise grid and print the table (make eval CKPT=..., make xsim CKPT=...)."""

    ckpt: Path
    """Checkpoint file (checkpoints/<task>/*.ckpt, made by a sweep)."""
    method: Optional[str] = None
    """Method from the registry; default: EBC for a policy checkpoint, POIR-DRIL for a POIR one."""
    sigma_init: tuple[float, ...] = (0.02, 0.1, 0.2, 0.3, 0.4)
    """Initial arm-joint noise levels."""
    sigma_action: tuple[float, ...] = (0.0,)
    """Action noise levels."""
    episodes: int = 10
    """Episodes per cell."""
    max_steps: int = 400
    """Control steps per episode."""
    seed: int = 0
    """Seed of the episode keys (the sweep's: same seed, grid and episodes give the sweep's episodes)."""
    device: Literal["any", "cpu", "gpu"] = "any"
    """gpu: fail unless jax sees a GPU; cpu: force the CPU; any: jax's default."""
    simulator: Literal["mjx", "robosuite", "both"] = "mjx"
    """mjx (vectorised), robosuite (the reference simulator, in --workers processes) or both side by side
    with a Fisher exact test per cell (make xsim)."""
    workers: int = 2
    """robosuite worker processes."""
    out: Optional[Path] = None
    """Also write the table to this file (markdown)."""
    planner: PlannerFlags = PlannerFlags()  # type: ignore[valid-type]
    """Planner settings replacing the checkpoint's (POIR methods only)."""


@dataclasses.dataclass(frozen=True)
class Compare:
    """One table across sweep runs, e.g. ablations (make ablations)."""

    runs: tyro.conf.Positional[tuple[Path, ...]]
    """Run folders (results/<name>)."""
    out: Optional[Path] = None
    """Also write the table to this file (markdown)."""


@dataclasses.dataclass(frozen=True)
class Report:
    """results/README.md from each published run's own files: setup, notes.md, tables, plots (make report)."""

    results: Path = Path("results")
    """Results folder: its run folders (config.json and summary.md), tables across runs, bench/ and expert/."""
    out: Optional[Path] = None
    """The page to write (default: <results>/README.md)."""
    check: bool = False
    """Write nothing; exit status 1 with one line if the page on disk differs from what would be generated."""
    tables: bool = False
    """First rewrite each published run's tables and plots from its cell records with this version's report code
    (nothing is simulated; a run published without its cells is left as it is)."""


@dataclasses.dataclass(frozen=True)
class Envs:
    """Export the robosuite tasks to MJX-ready MJCF under envs/ (make envs; needs robosuite)."""

    out: Path = Path("envs")
    """Output folder."""
    task: Annotated[tuple[Task, ...], tyro.conf.UseAppendAction] = ()  # type: ignore[valid-type]
    """Task to export, repeatable (default: all)."""
    check: bool = False
    """Only export the tasks whose files are missing."""


@dataclasses.dataclass(frozen=True)
class DemosGenerate:
    """Write robomimic HDF5 files of successful scripted-expert demos (make demos)."""

    tasks: tuple[Task, ...] = TASKS  # type: ignore[valid-type]
    """Tasks to record."""
    num: int = DEFAULT_NUM_DEMOS
    """Successful demonstrations per task."""
    seed: int = 0
    """Seed of the episodes."""
    sigma_init: float = 0.02
    """Initial arm-joint noise."""
    out: Path = Path("data/demos")
    """Output folder."""
    simulator: Literal["robosuite", "mjx"] = "robosuite"
    """robosuite (MuJoCo C, needs robosuite) or mjx (vectorised; -> <task>-mjx.hdf5)."""
    batch: int = 16
    """MJX episodes per compiled batch (GPU: 256-1024)."""
    x64: bool = False
    """Record MJX demos with float64 physics (jax_enable_x64): NutAssemblySquare's grasp needs it (see demos success)."""


@dataclasses.dataclass(frozen=True)
class DemosSuccess:
    """Measure the scripted expert's success rate and write a table (make expert-success)."""

    tasks: tuple[Task, ...] = TASKS  # type: ignore[valid-type]
    """Tasks to measure."""
    simulator: tuple[Literal["robosuite", "mjx"], ...] = ("robosuite",)
    """Simulators to measure in."""
    episodes: int = 100
    """Episodes per task and simulator."""
    seed: int = 1
    """Seed of the episodes."""
    sigma_init: float = 0.02
    """Initial arm-joint noise."""
    out: Path = Path("results/expert")
    """Output folder: success_<simulators>.{md,json}."""
    batch: int = 0
    """MJX episodes per compiled call (0: all at once). Each finished call's outcomes are kept in
    <out>/.partial/ until the tables are written, so an interrupted run resumes after them."""
    x64: bool = False
    """Run the MJX physics in float64 (jax_enable_x64). NutAssemblySquare's grasp needs it in MJX: the expert succeeds
    in 20 of 32 float32 episodes, 32 of 32 in float64 (docs/expert-data.md)."""


@dataclasses.dataclass(frozen=True)
class BenchEnv:
    """MJX vs robosuite control-step throughput (make bench-env) -> <out>/<name>.{json,md}."""

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


@dataclasses.dataclass(frozen=True)
class BenchPhysics:
    """MJX physics presets side by side (make bench-env): ms per physics substep, and the error against robosuite
    on the fidelity test's grasp-and-lift replay -> <out>/<name>.{json,md}."""

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


@dataclasses.dataclass(frozen=True)
class BenchPlanner:
    """POIR planner calls per second (make bench-planner) -> <out>/planner.{json,md}."""

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


@dataclasses.dataclass(frozen=True)
class BenchE2E:
    """Evaluated episodes per minute on Lift, per preset and method (make bench-e2e) -> <out>/e2e.{json,md}."""

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


@dataclasses.dataclass(frozen=True)
class BenchRobosuite:
    """Episodes in robosuite: bare stepping vs EBC and POIR-DRIL collection, plain and overlapped
    (make bench-robosuite) -> <out>/robosuite-e2e.{json,md}, each row written as it finishes."""

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


@dataclasses.dataclass(frozen=True)
class GpuCheck:
    """The prepared GPU run (make gpu-check): env, planner, end-to-end, sweep and expert stages in priority
    order, each under a deadline, each writing <out>/<stage>.json after every row; complete stages are skipped."""

    out: Path = Path("results/gpu")
    """Output folder (on the lent machine: $OUT): <stage>.json and summary.md."""
    dry_run: bool = False
    """The same stages at tiny sizes on the CPU, in this process (make test-current runs it)."""
    scratch: Path = Path("/tmp/poir-mjx-gpu-check")
    """Demos, checkpoints and the sweep's run folder (not results)."""
    stages: tuple[Literal["env", "planner", "e2e", "sweep", "expert"], ...] = ("env", "planner", "e2e", "sweep", "expert")
    """Stages to run (always in priority order)."""
    only: Optional[Literal["env", "planner", "e2e", "sweep", "expert"]] = None
    """Run this one stage here and now, no deadline (what the runner's child processes do)."""
