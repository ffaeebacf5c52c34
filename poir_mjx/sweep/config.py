"""A sweep's typed config: the grid, the methods, the data and the simulator, loaded with errors naming
the file and the field (``experiments/*.json``)."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import typing
from pathlib import Path
from typing import Literal

from poir_mjx.core.config import PRESETS, ConfigError, PlannerConfig, POIRConfig, apply_overrides, preset, to_dict
from poir_mjx.core.ranking import DEFAULT_RANKING, Ranking, quaternion_free, with_ranking
from poir_mjx.envs.layout import OBSERVATIONS, obs_groups
from poir_mjx.envs.physics import PhysicsPresetName, physics_preset, require_warp
from poir_mjx.envs.tasks import DEFAULT_NUM_DEMOS, TASKS
from poir_mjx.eval.methods import METHODS, get_method
from poir_mjx.sweep.run_folder import RETIRED, run_name_problem, upgrade_recorded
from poir_mjx.typed_config import NOISE, SEED, check, check_keys

Preset = Literal[tuple(PRESETS)]  # type: ignore[valid-type]
Task = Literal[TASKS]  # type: ignore[valid-type]
Simulator = Literal["mjx", "robosuite"]
DemoSimulator = Literal["robosuite", "mjx"]
DemoStyle = Literal["scripted", "human_like"]
Device = Literal["any", "cpu", "gpu"]
Observation = Literal[tuple(OBSERVATIONS)]  # type: ignore[valid-type]


@dataclasses.dataclass(frozen=True)
class SweepConfig:
    name: str
    """Run name: results go to results/<name>/."""
    preset: Preset = "cpu-small"
    """POIR config preset (cpu-small; cpu-can and cpu-square: the same 5x300 networks for the contact-rich tasks;
    paper)."""
    tasks: tuple[Task, ...] = ("lift",)
    """Tasks to evaluate."""
    methods: tuple[str, ...] = ("EBC", "POIR-DRIL")
    """Methods from the registry (poir_mjx/eval/methods.py: BC, EBC, POIR-L2, POIR-DRIL, POIR-MOREL, the
    controls POIR-noprior, POIR-prior and POIR-random, the online variants and the baselines)."""
    sigma_init: tuple[float, ...] = (0.02, 0.2, 0.4)
    """Initial arm-joint noise levels."""
    sigma_action: tuple[float, ...] = (0.0,)
    """Action noise levels."""
    seeds: tuple[int, ...] = (0,)
    """Training and evaluation seeds."""
    episodes: int = 10
    """Episodes per cell."""
    max_steps: int = 400
    """Control steps per episode (robosuite's horizon is 400)."""
    num_demos: int = DEFAULT_NUM_DEMOS
    """Scripted-expert demonstrations per task (ignored for tasks given in demo_files)."""
    demo_simulator: DemoSimulator = "robosuite"
    """Where the scripted expert records its demos: "robosuite" (MuJoCo C, needs robosuite) or "mjx"
    (vectorised in MJX, no robosuite: the path for a GPU machine)."""
    demo_batch: int = 16
    """MJX episodes per compiled batch when demo_simulator is "mjx" (GPU: 256-1024)."""
    demo_style: DemoStyle = "scripted"
    """How the scripted expert acts: "scripted" (its state machine alone) or "human_like" (an operator's
    variability on top: rotation wobble, speed per segment, pauses, a lateral approach waypoint, occasional
    re-grasps; poir_mjx/data/expert_human.py; files <task>[-mjx]-human.hdf5). Ignored for tasks in demo_files."""
    simulator: Simulator = "mjx"
    """Where the evaluation episodes run: "mjx" (vectorised, one compiled rollout: the GPU path) or
    "robosuite" (the reference: robosuite's own environment and controller in `workers` processes,
    the agent's calls batched across them; needs robosuite; online methods collect where
    `online.simulator` says, by default here too)."""
    workers: int = 2
    """robosuite worker processes when simulator is "robosuite" (0: one per CPU core); each holds up to 16
    environments, as many as the episodes need."""
    device: Device = "any"
    """"gpu" refuses to run unless jax sees a GPU (no silent CPU run), "cpu" forces the CPU, "any" takes jax's default."""
    demo_files: dict = dataclasses.field(default_factory=dict)
    """Optional {task: path} of robomimic HDF5 files to use instead of the scripted expert."""
    overrides: dict = dataclasses.field(default_factory=dict)
    """Dotted POIR config fields replacing the preset's values, e.g. {"train.epochs": 1} or
    {"online.total_env_steps": 20000}."""
    baseline_overrides: dict = dataclasses.field(default_factory=dict)
    """Per baseline method, dotted fields of its config replacing the preset's, e.g.
    {"DAC": {"total_env_steps": 20000}} (poir_mjx/baselines: each algorithm's Config)."""
    x64: bool = False
    """MJX physics in float64 (float32 once launched Square's nut mid-grasp); networks and planner stay float32."""
    observation: Observation = "low_dim"
    """What every network and reward sees: "low_dim", robomimic's low-dim set (hand position and quaternion, finger
    joints, object-state: 19 numbers for Lift, 23 for Can and Square), or "object", robosuite's object-state vector
    alone (object pose and object-to-gripper offset: 10 and 14 numbers), the paper's observation. The demos are read,
    the MJX and robosuite episodes observed and the checkpoints and cells keyed accordingly; the scripted expert still
    reads the full observation."""
    physics: PhysicsPresetName = "reference"
    """MJX physics preset (poir_mjx/envs/physics.py): "reference" (robosuite's solver options, MJX as released),
    "same-maths" (the solver patch and no floor pairs only), "fast" or "fast-capped" (results/bench/physics-cpu.md)
    for every MJX episode of the run: evaluation, online collection and baselines' training; "warp": MuJoCo Warp's
    kernels (``make venv STACK=warp``; evaluation and online collection, not the baselines or the oracle controls).
    MJX demos are recorded with the reference physics; robosuite episodes are robosuite's own."""
    ranking: Ranking = DEFAULT_RANKING
    """How every POIR method's planner ranks its candidates (poir_mjx/core/ranking.py): "balanced", the default
    (head-balanced selection, L2 without the quaternion dimensions: the fixes for the head lottery and L2's geometry,
    docs/diagnose.md), or "paper" (the k best returns, L2 over every dimension, as printed; every run published
    before the default changed, whose recorded configs lack this field, used it). `overrides` of planner fields win."""

    ZERO_OK = ("seeds", "workers")
    BOUNDS = {"seeds": SEED, "episodes": (1, 10**6), "max_steps": (1, 10**6), "num_demos": (1, 10**6),
              "demo_batch": (1, 2**16), "workers": (0, 1024), "sigma_init": NOISE, "sigma_action": NOISE}

    def cross_check(self, prefix: str) -> None:
        if run_name_problem(self.name):
            raise ConfigError(f"name: {run_name_problem(self.name)}")
        for field in ("sigma_init", "sigma_action"):  # each level names its cell file ("si=<level:g>")
            levels = getattr(self, field)
            same = next(((a, b) for i, a in enumerate(levels) for b in levels[i + 1:] if f"{a:g}" == f"{b:g}"), None)
            if same:
                raise ConfigError(f"{field}: {same[0]!r} and {same[1]!r} would share one cell file (both print as "
                                  f"{f'{same[0]:g}'}); give levels that differ in 6 significant digits")  # fmt: skip
        for m in self.methods:
            if m not in METHODS:
                raise ConfigError(f"methods: unknown method {m!r}; expected one of {', '.join(METHODS)}")
        if self.physics != "reference" and self.simulator == "robosuite" and not any(
                get_method(m).is_baseline or get_method(m).online for m in self.methods):  # fmt: skip
            raise ConfigError(f"physics: {self.physics!r} sets MJX's physics, and nothing in this run steps MJX "
                              "(field 'simulator' is 'robosuite' and no method trains online)")  # fmt: skip
        if physics_preset(self.physics).impl == "warp":
            require_warp("physics")
            odd = [m for m in self.methods if get_method(m).is_baseline or METHODS[m].oracle]
            if odd:
                raise ConfigError(f"physics: 'warp' shares contact buffers across a batch's episodes, which "
                                  f"{', '.join(odd)} (environments reset one by one, or rolled out inside an episode) "
                                  "do not support; use another physics preset or leave them out of 'methods'")  # fmt: skip
        base_config(self)  # the overrides, named "overrides: <dotted field>: ..."
        for name, ov in self.baseline_overrides.items():
            if name not in self.methods or not get_method(name).is_baseline:
                raise ConfigError(f"baseline_overrides: {name!r} is not a baseline in field 'methods'")
            if not isinstance(ov, dict):
                raise ConfigError(f"baseline_overrides.{name}: expected an object, got {ov!r}")
        for name in (m for m in self.methods if get_method(m).is_baseline):
            baseline_config(self, name, "baseline_overrides")
        for task, f in self.demo_files.items():
            if not isinstance(f, str):
                raise ConfigError(f"demo_files.{task}: must be a file path (a string), got {f!r}")
            if task not in TASKS or task not in self.tasks:
                raise ConfigError(f"demo_files: task {task!r} is not in field 'tasks'")
            if Path(f).is_dir():
                raise ConfigError(f"demo_files.{task}: {f} is a directory, expected a robomimic HDF5 file")
            if not Path(f).is_file():
                raise ConfigError(f"demo_files.{task}: no such file {f}")


def load_sweep_config(path: str | Path, recorded: bool = False) -> SweepConfig:
    """Parse and validate a sweep config file (``poir_mjx.typed_config``: the field types, then the cross-field
    rules above); errors name the file and the field: ``<file>: field '<dotted field>': <problem>``.

    recorded: the file is a run folder's ``config.json``, written by the sweep, perhaps by an older version: its
    retired fields are migrated (``run_folder.upgrade_recorded``) rather than refused."""
    path = Path(path)

    def no_duplicates(pairs):
        keys = [k for k, _ in pairs]
        dup = next((k for k in keys if keys.count(k) > 1), None)
        if dup is not None:
            raise ConfigError(f"{path}: field '{dup}' is given more than once")
        return dict(pairs)

    try:
        raw = json.loads(path.read_bytes().decode("utf-8"), object_pairs_hook=no_duplicates)
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such config file") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory, expected a sweep config file (JSON)") from None
    except ConfigError:
        raise
    except UnicodeDecodeError as e:
        raise ConfigError(f"{path}: not UTF-8 text (byte {e.start}); a sweep config is JSON") from None
    except (json.JSONDecodeError, ValueError, RecursionError) as e:  # bad JSON, a 5000-digit number, deep nesting
        why = "nested too deeply" if isinstance(e, RecursionError) else " ".join(str(e).split())[:200]
        raise ConfigError(f"{path}: not valid JSON ({why})") from None
    except OSError as e:
        raise ConfigError(f"{path}: cannot be read ({e.strerror})") from None
    if not isinstance(raw, dict):
        raise ConfigError(f"{path}: expected a JSON object")
    if recorded:
        raw = upgrade_recorded(raw)
    for field, instead in RETIRED.items():
        if field in raw:
            raise ConfigError(f"{path}: field '{field}' is no longer a sweep field; use {instead}")
    check_keys(raw, SweepConfig, str(path))
    if "name" not in raw:
        raise ConfigError(f"{path}: field 'name' is required")
    hints = typing.get_type_hints(SweepConfig)
    kw = {k: tuple(v) if typing.get_origin(hints[k]) is tuple and isinstance(v, list) else v for k, v in raw.items()}
    try:
        return check(SweepConfig(**kw))
    except ConfigError as e:
        field, _, problem = str(e).partition(": ")
        raise ConfigError(f"{path}: field '{field}': {problem}") from None


def base_config(cfg: SweepConfig) -> POIRConfig:
    """The POIR config every method of the sweep starts from: the preset, its `ranking`, then the `overrides`."""
    base = with_ranking(preset(cfg.preset), cfg.ranking, _ranked_groups(cfg))
    return apply_overrides(base, cfg.overrides) if cfg.overrides else base


def _ranked_groups(cfg: SweepConfig) -> tuple[str, ...]:
    """The observation groups the ranking's L2 dimensions come from: the tasks' (one base config serves them all,
    so their quaternion-free dimensions must agree, as they do for Lift, PickPlaceCan and NutAssemblySquare)."""
    if cfg.ranking == "paper":
        return ()
    groups = {task: obs_groups(task, observation=cfg.observation) for task in cfg.tasks}
    dims = {task: quaternion_free(g) for task, g in groups.items()}
    if len(set(dims.values())) > 1:
        raise ConfigError(f"ranking: {cfg.ranking!r} leaves the quaternions out of L2, and they sit at different "
                          f"dimensions of the tasks' {cfg.observation} observations ({dims}); run the tasks apart or "
                          "set overrides 'planner.l2_dims'")  # fmt: skip
    return next(iter(groups.values()))


def baseline_config(cfg: SweepConfig, method: str, source: str = "baseline_overrides"):
    """The config a baseline method trains with: its `preset` plus the sweep's overrides for it."""
    from poir_mjx.baselines.registry import get_baseline

    return get_baseline(method).config(cfg.preset, cfg.baseline_overrides.get(method), source)


def config_dict(cfg: POIRConfig, online: bool) -> dict:
    """The config as hashed: offline agents and cells do not depend on the online settings."""
    d = to_dict(cfg)
    if not online:
        d.pop("online")
    default = PlannerConfig()
    for f in PlannerConfig.HASH_AT_DEFAULT_OMITS:
        if getattr(cfg.planner, f) == getattr(default, f):
            d["planner"].pop(f)
    return d


def short_hash(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()[:16]
