"""The MJX physics settings of an environment: solver budget and the optional cost cuts, as one typed config.

``PhysicsConfig()`` is today's physics ("reference": robosuite's solver options as exported, unpatched MJX).
``physics_preset("fast")`` is the cheaper setting measured in ``make bench-env`` (results/bench/); every cut is
its own field, so each stays reachable alone. The settings reach the model through the MjSpec before it is
compiled (``edit_spec``: solver options, floor contacts) and MJX's solver through ``solver_patch`` while a step is traced
(``solver_scope``).
"""

from __future__ import annotations

import contextlib
import dataclasses
from typing import TYPE_CHECKING, Literal

from poir_mjx.typed_config import ConfigError, check

if TYPE_CHECKING:  # no mujoco import here: the option dataclasses (poir_mjx/options.py) name the presets
    import mujoco

PhysicsPresetName = Literal["reference", "same-maths", "fast", "fast-capped", "warp"]


@dataclasses.dataclass(frozen=True)
class PhysicsConfig:
    """MJX solver settings of a TaskEnv (the default is today's physics, robosuite's options)."""

    iterations: int = 100
    """Newton iterations at most per physics substep (robosuite and the exported model: 100). Measured on Lift:
    2.0 on average, 9 at most (issue 42)."""
    ls_iterations: int = 50
    """Line-search steps at most per Newton iteration (exported model: 50; measured about 5.3 on average)."""
    tolerance: float = 1e-8
    """Solver tolerance (relative cost improvement and gradient) that ends Newton early (exported model: 1e-8)."""
    linesearch_loop: Literal["scan", "while"] = "scan"
    """"scan": MJX's own line search (a ``lax.scan`` over ``lax.cond``, which under ``vmap`` runs all
    ``ls_iterations`` steps); "while": a ``lax.while_loop`` (``solver_patch``: the same steps and maths, ends when
    the batch's slowest search has converged; not reverse-mode differentiable)."""
    cone_hessian: Literal["dense", "blocks"] = "dense"
    """Newton's Hessian with elliptic cones: "dense" is MJX's (an nefc x nefc matrix assembled by one scatter per
    contact, then J^T C J); "blocks" adds J_c^T H_c J_c per contact to J^T diag(D active) J (``solver_patch``:
    the same maths in another summation order)."""
    floor_contacts: bool = True
    """False: the floor plane collides with nothing, which drops its candidate pairs (6 for Lift and PickPlaceCan,
    10 for NutAssemblySquare: the gripper's five collision geoms, out of the arm's reach, and the object's geoms,
    which reach the floor only after leaving the table). A load-time edit, envs/README.md."""

    max_contact_points: int = -1
    """MJX's contact cap (its ``max_contact_points`` numeric): at most this many contacts per contact dimension
    group, the deepest kept, so the constraint rows (and the solver's cost) no longer grow with every candidate
    pair. -1: no cap (every candidate pair's contacts: 344 for PickPlaceCan, 80 for Lift). A load-time edit."""

    impl: Literal["jax", "warp"] = "jax"
    """MJX's implementation: "jax" (MJX's own JAX pipeline, every version) or "warp" (MuJoCo Warp's kernels behind
    MJX's API: mujoco-mjx 3.17 with warp-lang 1.18.0, ``make venv STACK=warp``; CUDA GPUs and, slowly, CPUs). Warp
    runs MuJoCo's own solver, so the solver patch does not apply; its contact buffers are shared by a batch's
    episodes and sized for the batch when it is traced (``envs/warp.py``)."""
    warp_contacts: int = 0
    """MuJoCo Warp only: contacts kept per episode (its buffers hold this many times the batch size). 0: every
    candidate pair's contacts, as many as MJX's JAX pipeline allocates (80 for Lift, 344 for PickPlaceCan), which
    cannot overflow; a smaller budget is cheaper and drops the contacts past it when a batch has more."""

    SIGNED = ("max_contact_points",)
    ZERO_OK = ("warp_contacts",)
    BOUNDS = {"max_contact_points": (-1, 100_000), "warp_contacts": (0, 100_000)}

    def cross_check(self, prefix: str = "") -> None:
        if self.impl == "warp" and self.patched:
            raise ConfigError(f"{prefix}impl: 'warp' runs MuJoCo Warp's own solver; linesearch_loop and cone_hessian "
                              "patch MJX's JAX solver (leave them 'scan' and 'dense')")  # fmt: skip
        if self.impl == "jax" and self.warp_contacts:
            raise ConfigError(f"{prefix}warp_contacts: sizes MuJoCo Warp's buffers; set impl: 'warp' or leave it 0")

    @property
    def patched(self) -> bool:
        """Whether MJX's solver is patched (``solver_patch``) for this config."""
        return self.linesearch_loop != "scan" or self.cone_hessian != "dense"


REFERENCE = PhysicsConfig()
# The cheaper physics: iterations sized from the measured need (Newton: 2 on average, 9 at most; line search
# about 5 per iteration), with margin, and every same-maths cut (the solver patch, the floor's pairs). Not the
# default: measured against the reference and robosuite in results/bench/physics-cpu.md.
PHYSICS_PRESETS: dict[str, PhysicsConfig] = {
    "reference": REFERENCE,
    # only the cuts that keep the reference's maths (the solver patch, the floor's pairs, which never touch):
    # robosuite's iteration budget; "fast" is this with 10 / 8 iterations (which of the two costs its episodes)
    "same-maths": PhysicsConfig(linesearch_loop="while", cone_hessian="blocks", floor_contacts=False),
    "fast": PhysicsConfig(iterations=10, ls_iterations=8, linesearch_loop="while", cone_hessian="blocks",
                          floor_contacts=False),  # fmt: skip
    # fast, and at most 32 contacts per contact-dimension group (the deepest): PickPlaceCan's 344 candidate contacts
    # (1234 constraint rows) are mostly gripper-versus-bin-wall pairs far apart (issue 42)
    "fast-capped": PhysicsConfig(iterations=10, ls_iterations=8, linesearch_loop="while", cone_hessian="blocks",
                                 floor_contacts=False, max_contact_points=32),  # fmt: skip
    # MuJoCo Warp's kernels behind MJX's API, robosuite's solver options, the floor's pairs dropped
    "warp": PhysicsConfig(impl="warp", floor_contacts=False),
}


def physics_preset(name: str) -> PhysicsConfig:
    """The named physics (``PHYSICS_PRESETS``); an unknown name is a ConfigError listing the known ones."""
    if name not in PHYSICS_PRESETS:
        raise ConfigError(f"physics: unknown preset {name!r}; expected one of {', '.join(PHYSICS_PRESETS)}")
    return PHYSICS_PRESETS[name]


def as_physics(physics: PhysicsConfig | str | None) -> PhysicsConfig:
    """A checked PhysicsConfig from a config, a preset name, or None (the reference)."""
    if physics is None:
        return REFERENCE
    if isinstance(physics, str):
        physics = physics_preset(physics)
    if not isinstance(physics, PhysicsConfig):
        raise ConfigError(f"physics: expected a PhysicsConfig or a preset name, got {physics!r}")
    check(physics, "physics.")
    if physics.patched:  # refused here, before anything is built, on an MJX the patch was not written for
        from poir_mjx.envs import solver_patch

        solver_patch.check_version()
    if physics.impl == "warp":
        require_warp()
    return physics


def require_warp(field: str = "physics.impl") -> None:
    """A ConfigError naming `field` unless MJX can run MuJoCo Warp here (mjx 3.17 or newer, warp-lang installed)."""
    from poir_mjx.optional import warp_installed

    if not warp_installed():
        raise ConfigError(f"{field}: 'warp' needs mujoco-mjx 3.17 or newer with warp-lang 1.18.0 "
                          "(make venv STACK=warp)")  # fmt: skip


def edit_spec(spec: mujoco.MjSpec, physics: PhysicsConfig) -> mujoco.MjSpec:
    """Write the solver options (and, if asked, the floor's collision flags) into a task's spec before compiling."""
    spec.option.iterations = physics.iterations
    spec.option.ls_iterations = physics.ls_iterations
    spec.option.tolerance = physics.tolerance
    if not physics.floor_contacts:
        floor = spec.geom("floor")
        if floor is None:
            raise ConfigError("physics.floor_contacts: the model has no geom named 'floor'")
        floor.contype, floor.conaffinity = 0, 0
    if physics.max_contact_points != -1:
        spec.add_numeric(name="max_contact_points", data=[physics.max_contact_points])
    return spec


def solver_scope(physics: PhysicsConfig):
    """The scope in which an environment's MJX calls are traced: MJX's solver patched as `physics` asks, or as is."""
    if not physics.patched:
        return contextlib.nullcontext()
    from poir_mjx.envs import solver_patch

    return solver_patch.patched(while_linesearch=physics.linesearch_loop == "while",
                                block_hessian=physics.cone_hessian == "blocks")  # fmt: skip
