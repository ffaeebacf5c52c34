"""The planner's FLOP count from its shapes: equal to XLA's own count where XLA sees every FLOP (one horizon
step, all heads at once), and growing with the horizon where XLA's loop-body count does not."""

import dataclasses

import jax
import pytest

from poir_mjx.bench.flops import dense_flops_per_row, planner_matmul_flops
from poir_mjx.bench.planner import ACT, OBS, random_params
from poir_mjx.core import ensemble as ens
from poir_mjx.core.agent import POIR
from poir_mjx.core.config import PRESETS


def _agent(reward: str, horizon: int) -> POIR:
    base = PRESETS["cpu-small"]
    planner = dataclasses.replace(base.planner, reward=reward, horizon=horizon, num_trajectories=64, head_chunk=0)
    return POIR(dataclasses.replace(base, planner=planner), OBS, ACT)


def _xla_flops(fn, *args) -> float:
    cost = jax.jit(fn).lower(*args).compile().cost_analysis()
    cost = cost[0] if isinstance(cost, (list, tuple)) else cost
    if not isinstance(cost, dict) or "flops" not in cost:
        pytest.skip("this backend gives no cost analysis")
    return float(cost["flops"])


def test_dense_count_matches_xla_on_one_ensemble_application():
    agent = _agent("dril", 1)
    params = random_params(agent, 100, jax.random.PRNGKey(0))
    x = jax.random.normal(jax.random.PRNGKey(1), (50, OBS))
    ours = agent.config.ensemble_size * 50 * dense_flops_per_row(params.bc)
    xla = _xla_flops(lambda p, x: ens.apply_all(agent.bc_module, p, x), params.bc, x)
    assert ours <= xla <= 1.05 * ours  # XLA adds the biases and activations


@pytest.mark.parametrize("reward", ["dril", "morel", "l2"])
def test_planner_count_matches_xla_at_one_step_and_scales_with_the_horizon(reward):
    one, three = _agent(reward, 1), _agent(reward, 3)
    params = random_params(one, 300, jax.random.PRNGKey(0))
    obs, key = jax.random.normal(jax.random.PRNGKey(1), (OBS,)), jax.random.PRNGKey(2)
    ours = planner_matmul_flops(one, params)
    assert ours <= _xla_flops(one.plan, params, obs, key) <= 1.25 * ours
    # MOREL scores (s, a): at H 1 no model step is computed (XLA drops the unused next state), at H 3 two are
    model_step = one.head_layout()[0] * one.head_layout()[1] * dense_flops_per_row(params.wm)
    extra = 2 * model_step if reward == "morel" else 0
    assert planner_matmul_flops(three, params, episodes=4) == 4 * (3 * ours + extra)
