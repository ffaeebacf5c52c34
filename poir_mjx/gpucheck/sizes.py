"""The sizes of a GPU check: one typed, frozen config, two named instances (the GPU run and the dry run)."""

from __future__ import annotations

import dataclasses

from poir_mjx.envs.tasks import DEFAULT_NUM_DEMOS

# Priority order (issue 42): physics, the evaluator end to end, one paper-size cell, the expert; then the small
# sweep and the planner (measured on the first lease); MuJoCo Warp last, only where warp-lang was carried in parts.
STAGES = ("env", "e2e", "cell", "expert", "sweep", "planner", "warp")


@dataclasses.dataclass(frozen=True)
class Sizes:
    env_batches: tuple[int, ...]
    """Lift episodes per batched MJX step, in priority order (the reset is compiled once, at the largest)."""
    env_steps: int
    """Timed batched control steps per size."""
    env_physics: tuple[str, ...]
    """Physics presets timed side by side (poir_mjx/envs/physics.py: today's "reference", the cheaper "fast")."""
    planner_preset: str
    """The POIR preset whose planner is timed (paper: N 4000, H 5, K 27, 5x300)."""
    planner_batches: tuple[int, ...]
    """Episodes per planner call."""
    planner_calls: int
    """Timed calls per row (after a compiling call)."""
    expert_states: int
    """Expert states the L2 reward searches."""
    e2e_preset: str
    """The preset trained and evaluated end to end (EBC and POIR-DRIL, Lift, sigma_init 0.2)."""
    e2e_episodes: int
    """Episodes per end-to-end batch (the sweep stage reuses this batch shape)."""
    e2e_steps: int
    """Control steps per episode."""
    epochs: int
    """Training epochs (0: the preset's), given to the sweep and the e2e benchmark as the override train.epochs."""
    num_demos: int
    """Scripted-expert demos recorded in MJX for training."""
    demo_batch: int
    """MJX demo episodes per compiled batch."""
    sweep_sigma_init: tuple[float, ...]
    """The small sweep's noise levels; e2e_episodes / len(...) episodes each: the e2e batch shape."""
    cell_task: str
    """The paper-size cell's task (the paper's widest gap: PickPlaceCan at sigma_init 0.1)."""
    cell_preset: str
    """Its POIR preset (paper: K 27, 5x300 networks, N 4000, H 5), trained on the device from the carried demos."""
    cell_methods: tuple[str, ...]
    """Its methods, on the same episodes (paired)."""
    cell_sigma_init: float
    """Its initial arm-joint noise."""
    cell_episodes: int
    """Its episodes per method."""
    expert_tasks: tuple[str, ...]
    """Tasks whose scripted expert's MJX success is measured."""
    expert_episodes: int
    """Episodes per task."""
    expert_steps: int
    """Control steps per expert episode (0: the expert's own budget)."""
    deadlines: tuple[tuple[str, int], ...]
    """(stage, seconds): a stage still running then is stopped; what it wrote stays."""
    budget_s: int
    """All stages together; each stage gets at most what is left."""


GPU = Sizes(
    env_batches=(4096, 1024), env_steps=20, env_physics=("fast", "reference"),
    planner_preset="paper", planner_batches=(1, 64), planner_calls=5, expert_states=30_000,
    e2e_preset="cpu-small", e2e_episodes=1024, e2e_steps=400, epochs=0, num_demos=DEFAULT_NUM_DEMOS, demo_batch=256,
    sweep_sigma_init=(0.02, 0.1, 0.2, 0.4),
    cell_task="pick_place_can", cell_preset="paper", cell_methods=("EBC", "POIR-random", "POIR-DRIL"),
    cell_sigma_init=0.1, cell_episodes=64,
    expert_tasks=("pick_place_can", "nut_assembly_square"), expert_episodes=100, expert_steps=0,
    deadlines=(("env", 150), ("e2e", 150), ("cell", 240), ("expert", 120), ("sweep", 60), ("planner", 60),
               ("warp", 150)),
    budget_s=480,
)  # fmt: skip
# Deadlines from the first H200 run (results/gpu/notes.md): each MJX Lift program compiled in 28-39 s, so env
# needed 191 s (100 s stopped it before its first row); the planner stage took 77 s; no MJX demo batch had
# finished in e2e's 170 s. So the demos are now recorded on a CPU and carried (make gpu-carry -> .gpu-demos/), and
# the budget goes to the stages issue 42 puts first: env, e2e (1024 episodes x 400 steps), the paper-size cell.
# The dry run's shapes are tests/eval/test_sweep.py's tiny sweep and MJX demos (4-episode batches of 4 steps,
# 1 epoch, demos in batches of 2) and its expert rollout is the demos' own: in one pytest process the
# compiled programs are shared, so the dry run adds few compilations to make test-current. Its env stage times
# the fast preset alone and its cell runs e2e's two methods: the reference physics and the evaluators are e2e's
# programs already (each MJX program costs the dry run about 3 minutes of XLA on a CPU).
DRY = Sizes(
    env_batches=(1,), env_steps=2, env_physics=("fast",),
    planner_preset="cpu-small", planner_batches=(1, 2), planner_calls=2, expert_states=500,
    e2e_preset="cpu-small", e2e_episodes=4, e2e_steps=4, epochs=1, num_demos=6, demo_batch=2,
    sweep_sigma_init=(0.02, 0.3),
    cell_task="lift", cell_preset="cpu-small", cell_methods=("EBC", "POIR-DRIL"), cell_sigma_init=0.1,
    cell_episodes=4,  # the e2e batch: its EBC and POIR-DRIL programs serve the cell and the sweep too
    expert_tasks=("lift",), expert_episodes=2, expert_steps=0,
    deadlines=tuple((s, 1800) for s in STAGES), budget_s=3600,
)  # fmt: skip


def overrides(sizes: Sizes) -> dict:
    """The POIR config fields the sizes replace (the sweep config's "overrides")."""
    return {"train.epochs": sizes.epochs} if sizes.epochs else {}


def deadline(sizes: Sizes, stage: str) -> int:
    return dict(sizes.deadlines)[stage]
