"""Typed, frozen configuration of the POIR core, and the named presets ``cpu-small`` and ``paper``."""

from __future__ import annotations

import dataclasses
from typing import Literal, get_args

from poir_mjx import typed_config
from poir_mjx.typed_config import ConfigError, check, check_keys

Reward = Literal["l2", "dril", "morel"]
REWARDS = get_args(Reward)
__all__ = ["ConfigError", "POIRConfig", "REWARDS", "check", "check_keys", "from_dict"]


@dataclasses.dataclass(frozen=True)
class MLPConfig:
    layers: int = 5
    """Number of Dense layers, the output layer included (paper: 5)."""
    width: int = 300
    """Hidden units per hidden layer (paper: 300)."""
    activation: Literal["relu", "tanh", "gelu"] = "relu"
    """Hidden activation (paper: relu)."""


@dataclasses.dataclass(frozen=True)
class TrainConfig:
    epochs: int = 500
    """Passes over the expert data (paper: 500)."""
    batch_size: int = 256
    """Minibatch size per ensemble member (paper: 256)."""
    learning_rate: float = 1e-4
    """Adam learning rate (paper: 1e-4)."""
    beta1: float = 0.9
    """Adam beta1."""
    beta2: float = 0.999
    """Adam beta2."""


@dataclasses.dataclass(frozen=True)
class PlannerConfig:
    num_trajectories: int = 4000
    """N, sampled trajectories per planner call (paper: 4000)."""
    horizon: int = 5
    """H, imagined steps per trajectory (paper: 5)."""
    sigma: float = 0.2
    """Std of the Gaussian noise on the prior's (normalised) actions (paper: 0.2)."""
    top_k: int = 10
    """The returned action averages the first actions of the k best trajectories (k=1: argmax).
    The paper does not state its k; 10 is our choice."""
    reward: Reward = "dril"
    """Imitation reward: L2 distance to expert states, DRIL (BC disagreement), MOREL (model disagreement)."""
    use_prior: bool = True
    """False gives the ablation 'POIR without BC prior': candidate actions uniform in the bounds."""
    l2_chunk: int = 4096
    """Expert states per chunk in the exact nearest-neighbour search (bounds memory)."""
    l2_shortlist: int = 2048
    """Expert states the exact L2 search measures first, per head: those nearest to the centre of the head's imagined
    states at a step, 256 at a time, until the triangle inequality certifies each query's nearest state; the queries
    it cannot certify are scanned against every expert state (core/nearest.py). The same distances to float32
    rounding, far fewer measured (make bench-l2); 0: always the full scan."""
    l2_approx_size: int = 0
    """If > 0, the L2 reward searches a fixed random subset of this many expert states (approximate)."""
    head_chunk: int = 0
    """Heads the DRIL and MOREL rewards apply at a time (each of the K heads scores every imagined
    state, K x N states); 0: all K at once. It bounds memory, not the result: at paper size one hidden
    layer is 27 x 4023 x 300 floats (130 MB) per episode, 67 GB for 512 episodes at once; 3: 7 GB."""
    reward_timing: Literal["next_state", "current_state"] = "next_state"
    """When L2 and DRIL score a step: "next_state" scores the predicted state s^_{t+1} that action a~_t
    leads to (every step's action is judged, the last predicted state too); "current_state" is the
    algorithm as printed, r(s^_t, a~_t) for t = 1..H, whose first term is the same for every
    trajectory (all returns tie at H = 1) and which never scores the last predicted state. MOREL
    always scores (s^_t, a~_t): its disagreement is about the transition a~_t starts."""
    selection: Literal["top_k", "random", "head_balanced"] = "top_k"
    """How the top_k trajectories are chosen: "top_k" (the paper: the k largest returns), "random"
    (a control: k drawn uniformly among the N real trajectories, the returns ignored), which separates
    what the prior's noise does from what the reward's ranking does, or "head_balanced" (the best
    max(1, top_k // K) of every head, averaged over all heads: the ranking chooses noise within a head,
    never which head; core/selection.py)."""
    scoring: Literal["own_model", "head_centred", "all_models"] = "own_model"
    """What a trajectory's score is: "own_model" (the paper as printed: its return under the one world model
    its head rolled it through), "head_centred" (that return minus its head's mean return: a head's own model
    error no longer ranks its trajectories as a block) or "all_models" (its action sequence rolled open-loop
    through every world model of the ensemble, the mean return minus scoring_lambda times their std: the
    paper's "average reward over all ensemble members"; K times the world-model and reward cost)."""
    scoring_lambda: float = 0.0
    """With scoring "all_models": the score is mean - scoring_lambda * std of the K models' returns."""
    gripper_noise: Literal["gaussian", "flip"] = "gaussian"
    """The candidates' gripper action: "gaussian" (the paper: sigma noise like every dimension; robosuite acts
    on the sign only, and the expert's commands sit at the bounds, so the noise rarely changes what the robot
    does) or "flip" (a full open or close command, the prior's sign flipped with probability
    gripper_flip_prob, so the ranking can choose between opening and closing)."""
    gripper_flip_prob: float = 0.1
    """With gripper_noise "flip": the probability that a candidate's gripper command is the prior's reversed."""
    l2_dims: tuple[int, ...] = ()
    """The observation dimensions the L2 reward measures (indices into the policy's observation vector); empty:
    all. E.g. Lift without the two quaternions (robomimic's low-dim layout): 0 1 2 7 8 9 10 11 16 17 18.
    The nearest expert state is searched in those dimensions only."""
    dril_units: Literal["normalized", "action"] = "normalized"
    """The space DRIL measures the BC heads' disagreement in: "normalized" (the planner's normalised actions:
    each dimension divided by the expert's std, so a rotation dimension with std 0.012 weighs 80 times a
    position one) or "action" (robosuite's action units, the space the raw-trained heads were fitted in)."""
    disagreement: Literal["raw", "excess"] = "raw"
    """DRIL / MOREL rewards: "raw" (the paper: minus the ensemble's disagreement) or "excess" (minus the
    disagreement beyond the expert data's own level, its `disagreement_quantile` quantile on the expert
    transitions, as the DRIL paper's clipped cost: states as certain as the expert's tie)."""
    disagreement_quantile: float = 0.98
    """The quantile of the expert data's own disagreement that "excess" subtracts (DRIL paper: 0.98)."""
    matmul: Literal["default", "float32", "tf32", "bfloat16"] = "default"
    """The networks' matmuls when acting and planning (BC heads, world models; training is always "default"):
    "default" follows jax_default_matmul_precision (the command line pins it to true float32 on accelerators,
    devices.pin_precision; a CPU computes true float32), "float32" is true float32 whatever the process says, "tf32" / "bfloat16" inputs rounded to TF32 (10-bit mantissa) or bfloat16
    with float32 accumulation: tensor-core speed on a GPU, the same numbers emulated on a CPU (core/ensemble.py).
    The physics and the L2 reward's distances stay float32."""

    ZERO_OK = ("l2_approx_size", "l2_shortlist", "head_chunk", "scoring_lambda", "l2_dims")
    EMPTY_OK = ("l2_dims",)
    UNIT = ("gripper_flip_prob",)
    # Fields added after cells were first recorded: left out of the config's hash while at their default, so the
    # cells and checkpoints recorded before them keep their hashes (poir_mjx/sweep/config.config_dict).
    HASH_AT_DEFAULT_OMITS = ("scoring", "scoring_lambda", "gripper_noise", "gripper_flip_prob", "dril_units", "l2_dims",
                             "matmul", "l2_shortlist")  # fmt: skip

    def cross_check(self, prefix: str) -> None:
        if self.dril_units != "normalized" and self.disagreement == "excess":
            raise ConfigError(f"{prefix}dril_units: {self.dril_units!r} needs disagreement 'raw' (the expert "
                              "data's level that 'excess' subtracts is measured in normalised units)")  # fmt: skip
        if self.top_k > self.num_trajectories:
            raise ConfigError(f"{prefix}top_k: {self.top_k} exceeds num_trajectories {self.num_trajectories}")
        if not 0 < self.disagreement_quantile <= 1:
            raise ConfigError(f"{prefix}disagreement_quantile: must be in (0, 1], got {self.disagreement_quantile}")


@dataclasses.dataclass(frozen=True)
class NormalizerConfig:
    """Floors on the expert data's per-dimension std (environment units); all zeros: the paper's plain
    standardisation (std as measured, at least 1e-6). See poir_mjx/core/normalizer.py."""

    position_std_floor: float = 0.01
    """Smallest std of a position dimension, in metres (end effector, object, gripper-to-object)."""
    quaternion_std_floor: float = 0.05
    """Smallest std of a quaternion component (0.05 is a tilt of about 6 degrees)."""
    gripper_std_floor: float = 0.005
    """Smallest std of a gripper finger joint, in metres (fully open to closed is about 0.04)."""
    action_std_floor: float = 0.0
    """Smallest std of an action dimension (robosuite's actions lie in [-1, 1]). 0: the planner's noise
    (sigma x std) stays as small as the expert's own spread; a floor of 0.05 quadruples it on the
    rotation dimensions (std 0.012-0.04) and cost POIR-DRIL 29/30 -> 24/30 successes on Lift at
    sigma_init 0.02 (results/ablations.md)."""
    clip: float = 0.0
    """If > 0, normalised states the networks and rewards see (real and imagined) are clipped to
    [-clip, clip]; 0 leaves them unbounded (the paper)."""


@dataclasses.dataclass(frozen=True)
class OnlineConfig:
    """Online fine-tuning of the world model on the agent's own deployment transitions (paper, section 5)."""

    total_env_steps: int = 500_000
    """Environment steps collected per run, rounded up to whole rounds (paper: 500k)."""
    num_envs: int = 25
    """Episodes collected in parallel; a round is num_envs whole episodes of the sweep's max_steps."""
    eval_every: int = 50_000
    """Evaluate (the sweep's `episodes` episodes) at the first round end past each multiple (paper: 50k)."""
    buffer_capacity: int = 500_000
    """Ring-buffer size for online transitions (oldest overwritten first; paper: keeps all 500k)."""
    updates_per_env_step: float = 1.0
    """World-model gradient steps per collected environment step (the paper does not state its ratio)."""
    mix_start: float = 0.0
    """Fraction of online transitions in each batch at the first gradient step (paper: 0.0)."""
    mix_increment: float = 0.05
    """Added to the online fraction every mix_every gradient steps (paper: 0.05)."""
    mix_every: int = 100
    """Gradient steps between increments (paper: 100)."""
    mix_max: float = 0.5
    """Cap on the online fraction (paper: 0.5)."""
    simulator: Literal["sweep", "mjx", "robosuite"] = "sweep"
    """Where the deployment episodes are collected: "mjx" (vectorised, one compiled function per round:
    the GPU path), "robosuite" (robosuite's workers, the planner batched across the running episodes)
    or "sweep" (the sweep's own simulator). Evaluations run in the sweep's simulator either way."""

    UNIT = ("mix_start", "mix_max")

    def cross_check(self, prefix: str) -> None:
        if self.updates_per_env_step <= 0:
            raise ConfigError(f"{prefix}updates_per_env_step: must be > 0, got {self.updates_per_env_step}")


@dataclasses.dataclass(frozen=True)
class POIRConfig:
    ensemble_size: int = 27
    """K, networks in the BC and world-model ensembles (paper: 27)."""
    bc: MLPConfig = MLPConfig()
    """BC policy network."""
    world_model: MLPConfig = MLPConfig()
    """World-model network (predicts the normalised state change)."""
    train: TrainConfig = TrainConfig()
    """Optimisation of both ensembles."""
    planner: PlannerConfig = PlannerConfig()
    """MPPI-style planner."""
    normalize: bool = True
    """Normalise observations and actions with the expert data's mean/std (POIR: yes; BC/EBC: no)."""
    bc_space: Literal["normalized", "weighted", "raw"] = "raw"
    """The spaces POIR's BC prior is trained in (the planner converts to and from its normalised
    spaces): "normalized" (the paper: normalised states to normalised actions, every action dimension
    weighing the same in the loss, the gripper one seventh), "weighted" (the same, the loss weighted by
    each action dimension's variance: the squared error in action units) or "raw" (environment units in
    and out: exactly EBC's ensemble, the same weights for the same seed). Measured in
    docs/results-prior.md; without normalisation (BC, EBC) all three are the same."""
    normalizer: NormalizerConfig = NormalizerConfig()
    """Std floors and clipping of the normalisation (used when normalize is true)."""
    action_low: float = -1.0
    """Lower action bound (robosuite OSC_POSE and gripper: -1)."""
    action_high: float = 1.0
    """Upper action bound (+1)."""
    online: OnlineConfig = OnlineConfig()
    """Online fine-tuning (used by the "POIR-<reward> online" methods only)."""

    SIGNED = ("action_low", "action_high")

    def cross_check(self, prefix: str) -> None:
        if not self.action_low < self.action_high:
            raise ConfigError(f"{prefix}action_low: must be below action_high")

    def validate(self) -> POIRConfig:
        return check(self)


def to_dict(cfg) -> dict:
    return dataclasses.asdict(cfg)


def apply_overrides(cfg, overrides: dict, source: str = "overrides"):
    """Replace dotted fields of a config dataclass (e.g. {"online.total_env_steps": 20000} on a POIRConfig);
    unknown or invalid ones raise ConfigError."""
    d = to_dict(cfg)
    for dotted, value in overrides.items():
        node, parts = d, dotted.split(".")
        for part in parts[:-1]:
            if not isinstance(node.get(part), dict):
                raise ConfigError(f"{source}: '{dotted}' is not a config field")
            node = node[part]
        if parts[-1] not in node or isinstance(node[parts[-1]], dict):
            raise ConfigError(f"{source}: '{dotted}' is not a config field")
        node[parts[-1]] = value
    return from_dict(d, type(cfg), source)


def offline_config(cfg: POIRConfig) -> POIRConfig:
    """`cfg` with the online settings at their defaults: what identifies offline weights and offline cells."""
    return dataclasses.replace(cfg, online=OnlineConfig())


check_fields = check_keys  # the name the loaders use


def from_dict(d: dict, cls=None, source: str = "config"):
    """A POIR config (or `cls`) from plain data, checked (``poir_mjx.typed_config.from_dict``)."""
    return typed_config.from_dict(d, POIRConfig if cls is None else cls, source)


# Trains in under a minute and plans in milliseconds on 2 CPU cores. Fewer epochs than the paper's 500, so a 10x
# larger learning rate: at 1e-4 x 30 epochs EBC lifted the cube in 0 of 10 episodes at sigma_init 0.02; at 1e-3 x
# 100 epochs in 10 of 10 (robosuite, 200 demos).
_CPU_SMALL = POIRConfig(
    ensemble_size=5,
    bc=MLPConfig(layers=3, width=64),
    world_model=MLPConfig(layers=3, width=64),
    train=TrainConfig(epochs=100, batch_size=256, learning_rate=1e-3),
    planner=PlannerConfig(num_trajectories=256, horizon=5, sigma=0.2, top_k=5),
    # Lift on 2 CPU cores steps about 20 episode-steps/s in MJX: 20k steps is ~20 minutes a cell.
    online=OnlineConfig(total_env_steps=20_000, num_envs=16, eval_every=10_000, buffer_capacity=20_000),
)

# PickPlaceCan's smallest measured preset at which EBC reaches 0.8 at sigma_init 0.02 (robosuite, 200 scripted demos,
# 30 episodes; experiments/presets/can-ebc-*.json): 3x256 x 300 epochs 0.53, 4x256 0.23, the paper's 5x300 x 500
# epochs at 3e-4 0.80. NutAssemblySquare at these sizes: 26/30 = 0.87 (presets/square-ebc-d5w300.json; smaller sizes
# not tried there). The planner stays cpu-small's (N 256, K 5): POIR plans at CPU speed.
_CPU_CONTACT = dataclasses.replace(
    _CPU_SMALL, bc=MLPConfig(layers=5, width=300), world_model=MLPConfig(layers=5, width=300),
    train=TrainConfig(epochs=500, batch_size=256, learning_rate=3e-4))

PRESETS: dict[str, POIRConfig] = {
    "cpu-small": _CPU_SMALL,
    "cpu-can": _CPU_CONTACT,
    "cpu-square": _CPU_CONTACT,  # the same config as cpu-can, so the same checkpoint and cell hashes
    # The paper's sizes (Appendix): K 27, 5x300 MLPs, N 4000, H 5, sigma 0.2, 500 epochs;
    # online: 500k steps, evaluation every 50k. Rewards apply 3 of the 27 heads at a time (memory). The L2 search
    # scans every expert state, as when the H200 timed this preset: the shortlist is measured on a CPU only so far.
    "paper": POIRConfig(planner=PlannerConfig(head_chunk=3, l2_shortlist=0)),
}


def preset(name: str) -> POIRConfig:
    if name not in PRESETS:
        raise ConfigError(f"preset: unknown preset {name!r}; expected one of {sorted(PRESETS)}")
    return PRESETS[name]
