"""The planner's matrix-product FLOPs per call, counted from its shapes.

XLA's cost analysis (``compiled.cost_analysis()``) counts the body of a loop once, not once per trip: the
planner's ``lax.scan`` over the horizon, ``lax.map`` over head chunks and the L2 reward's scan over expert
chunks hide almost all of its work from it (at paper size it reported 3.4e8 FLOPs for a DRIL call that does
about 3.2e11). This count follows ``POIR.rollouts`` instead: per horizon step, on every cell of the [K, M]
layout (padding included, since it is computed too), the prior (head k on its own states), the world model
(likewise; not at the last step where the reward scores (s, a), since XLA drops that unused step), and the
reward: DRIL applies all K BC heads to every cell, MOREL all K world-model heads, L2 one
[cells, d] x [d, E] product (E padded to whole chunks). Only the Dense layers' products (2 x in x out per
row) and L2's distance product count: biases, activations, top-k and L2's refinement are left out, so it is
a slight undercount, never an overcount (checked against XLA on loop-free code in tests/bench).
"""

from __future__ import annotations

import jax


def dense_flops_per_row(stacked_params) -> int:
    """2 x in x out summed over one member's Dense kernels (stacked [K, in, out] leaves named "kernel")."""
    total = 0
    for path, leaf in jax.tree_util.tree_flatten_with_path(stacked_params)[0]:
        if getattr(path[-1], "key", None) == "kernel":
            total += 2 * int(leaf.shape[-2]) * int(leaf.shape[-1])
    return total


def planner_matmul_flops(agent, params, episodes: int = 1) -> int:
    """Matrix-product FLOPs of `episodes` calls of ``agent.plan`` (see the module docstring)."""
    pc = agent.config.planner
    k, m = agent.head_layout()
    cells = k * m
    bc, wm = dense_flops_per_row(params.bc), dense_flops_per_row(params.wm)
    per_step = cells * bc if pc.use_prior else 0
    if pc.reward == "dril":
        per_step += k * cells * bc
    elif pc.reward == "morel":
        per_step += k * cells * dense_flops_per_row(params.reward_wm)
    elif pc.reward == "l2":
        e, d = params.expert_states.shape
        e = min(e, pc.l2_approx_size) if pc.l2_approx_size else e
        chunk = min(pc.l2_chunk, e)
        per_step += 2 * cells * d * (-(-e // chunk) * chunk)
    # The model steps: where the reward scores (s, a), the last step's next state is unused and XLA drops it.
    model_steps = pc.horizon if agent.scores_next_state() else pc.horizon - 1
    return episodes * (pc.horizon * per_step + model_steps * cells * wm)
