"""The options of each subcommand: one frozen dataclass per subcommand, its field docstrings the help text.

Only light imports here (no jax): the parser is built from these on every call, ``--help`` included.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Annotated, Literal, Optional

import tyro

from poir_mjx.flags import flags_type
from poir_mjx.core.config import PlannerConfig, POIRConfig
from poir_mjx.core.ranking import DEFAULT_RANKING, Ranking
from poir_mjx.envs.physics import PhysicsPresetName
from poir_mjx.envs.tasks import DEFAULT_NUM_DEMOS, TASKS
from poir_mjx.outputs import file_pair
from poir_mjx.typed_config import NOISE, SEED

Task = Literal[TASKS]  # type: ignore[valid-type]

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

    def outputs(self):
        """What the command writes, checked before any work (poir_mjx/outputs.py; the run folder: run_sweep)."""
        return [(self.results, "folder", "--results"), (self.data, "folder", "--data"),
                (self.checkpoints, "folder", "--checkpoints")]


@dataclasses.dataclass(frozen=True)
class Eval:
    """Evaluate one checkpoint on a noise grid and print the table (make eval CKPT=..., make xsim CKPT=...)."""

    ZERO_OK = ("seed",)
    BOUNDS = {"seed": SEED, "episodes": (1, 10**6), "max_steps": (1, 10**6), "workers": (1, 1024),
              "sigma_init": NOISE, "sigma_action": NOISE}

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
    ranking: Ranking = DEFAULT_RANKING
    """How a POIR method's planner ranks its candidates: "balanced" (head-balanced selection, L2 without the
    quaternions: the default) or "paper" (as printed); poir_mjx/core/ranking.py. --planner.* flags win."""
    planner: PlannerFlags = PlannerFlags()  # type: ignore[valid-type]
    """Planner settings replacing the checkpoint's (POIR methods only)."""
    physics: PhysicsPresetName = "reference"
    """MJX physics preset (poir_mjx/envs/physics.py: reference, same-maths, fast, fast-capped, warp); robosuite is
    robosuite's own."""

    def outputs(self):
        return [] if self.out is None else [(self.out, "file", "--out")]


@dataclasses.dataclass(frozen=True)
class Compare:
    """One table across sweep runs, e.g. ablations (make ablations)."""

    runs: tyro.conf.Positional[tuple[Path, ...]]
    """Run folders (results/<name>)."""
    out: Optional[Path] = None
    """Also write the table to this file (markdown)."""
    versus: tuple[str, ...] = ()
    """RUN:METHOD, e.g. results/cpu-prior:EBC: a second table, every other row's successes minus that row's, matched
    cell by cell (task, sigma_init, training seed), with Fisher / Cochran-Mantel-Haenszel p; the run is added to the
    runs compared if it is not among them. Several (e.g. one run per training seed) form one reference row of all
    their cells; two with the same cell are refused."""
    methods: tuple[str, ...] = ()
    """Only these methods' rows (and the --versus rows); empty: every method of every run."""

    EMPTY_OK = ("methods", "versus")

    def outputs(self):
        return [] if self.out is None else [(self.out, "file", "--out")]


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

    def outputs(self):
        if self.check:
            return []
        return [(self.out, "file", "--out") if self.out else (self.results / "README.md", "file", "--results")]


@dataclasses.dataclass(frozen=True)
class Envs:
    """Export the robosuite tasks to MJX-ready MJCF under envs/ (make envs; needs robosuite)."""

    EMPTY_OK = ("task",)

    out: Path = Path("envs")
    """Output folder."""
    task: Annotated[tuple[Task, ...], tyro.conf.UseAppendAction] = ()  # type: ignore[valid-type]
    """Task to export, repeatable (default: all)."""
    check: bool = False
    """Only export the tasks whose files are missing."""

    def outputs(self):
        return [(self.out, "folder", "--out")]


@dataclasses.dataclass(frozen=True)
class DemosGenerate:
    """Write robomimic HDF5 files of successful scripted-expert demos (make demos)."""

    ZERO_OK = ("seed",)
    BOUNDS = {"seed": SEED, "num": (1, 10**6), "batch": (1, 2**16), "sigma_init": NOISE}

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
    demo_style: Literal["scripted", "human_like"] = "scripted"
    """scripted (the state machine alone) or human_like (rotation wobble, speed per segment, pauses, a lateral
    approach waypoint, occasional re-grasps; -> <task>[-mjx]-human.hdf5)."""

    def outputs(self):
        return [(self.out, "folder", "--out")]


@dataclasses.dataclass(frozen=True)
class DemosSpread:
    """The action spread of demo sets side by side: std per action dimension, rotation std, demo lengths, gripper
    commands (docs/expert-data.md)."""

    data: tuple[Path, ...]
    """robomimic HDF5 files (e.g. data/demos/lift.hdf5 data/demos/lift-human.hdf5), one column each."""
    out: Optional[Path] = None
    """Also write the table to this file (markdown) and the numbers beside it (.json)."""

    def outputs(self):
        if self.out is None:
            return []
        return [(self.out, "file", "--out"), (Path(self.out).with_suffix(".json"), "file", "--out")]


@dataclasses.dataclass(frozen=True)
class DemosCompact:
    """Copy robomimic files keeping what training reads (actions, low-dim observations, float32): the same
    transitions and digest in a fraction of the size, to carry to an offline GPU machine (make gpu-carry)."""

    data: tuple[Path, ...]
    """The robomimic files to copy."""
    out: Path = Path(".gpu-demos")
    """Output folder: <out>/<the file's name> for each."""

    def outputs(self):
        return [(self.out, "folder", "--out"), *((self.out / Path(d).name, "file", "--out") for d in self.data)]


@dataclasses.dataclass(frozen=True)
class DemosSuccess:
    """Measure the scripted expert's success rate and write a table (make expert-success)."""

    ZERO_OK = ("seed", "batch")
    BOUNDS = {"seed": SEED, "episodes": (1, 10**6), "batch": (0, 2**16), "sigma_init": NOISE}

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
    physics: PhysicsPresetName = "reference"
    """MJX physics preset (poir_mjx/envs/physics.py: reference, same-maths, fast, fast-capped, warp); other than
    reference, the tables are success_<simulators>_<physics>.{md,json}."""

    def outputs(self):
        tag = self.tag
        return [(self.out, "folder", "--out"), *file_pair(self.out, f"success_{tag}", "--out")]

    @property
    def tag(self) -> str:
        """The tables' file name tag: the simulators, and the physics preset other than reference."""
        return "_".join(self.simulator) + ("" if self.physics == "reference" else f"_{self.physics}")


# The GPU check's stages (poir_mjx/gpucheck/sizes.py STAGES, in its priority order; a test keeps the two equal)
GpuStage = Literal["env", "e2e", "cell", "expert", "sweep", "planner", "warp"]


@dataclasses.dataclass(frozen=True)
class GpuCheck:
    """The prepared GPU run (make gpu-check): env, end-to-end, a paper-size cell, expert, sweep, planner and (where
    warp-lang was carried) MuJoCo Warp stages in priority order, each under a deadline, each writing <out>/<stage>.json after every row; complete stages are
    skipped."""

    out: Path = Path("results/gpu")
    """Output folder (on the lent machine: $OUT): <stage>.json and summary.md."""
    dry_run: bool = False
    """The same stages at tiny sizes on the CPU, in this process (make test-current runs it)."""
    scratch: Path = Path("/tmp/poir-mjx-gpu-check")
    """Demos, checkpoints and the sweep's run folder (not results)."""
    stages: tuple[GpuStage, ...] = ("env", "e2e", "cell", "expert", "sweep", "planner", "warp")
    """Stages to run (always in priority order)."""
    only: Optional[GpuStage] = None
    """Run this one stage here and now, no deadline (what the runner's child processes do)."""
    demos: Path = Path(".gpu-demos")
    """Demo files recorded on a CPU and carried (make gpu-carry: <task>.hdf5, compact copies); a task without one
    has its demos recorded in MJX on the device."""

    def outputs(self):
        return [(self.out, "folder", "--out"), (self.scratch, "folder", "--scratch")]
