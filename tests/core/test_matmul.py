"""PlannerConfig.matmul (issue 42): the networks' matmuls at TF32 or bfloat16 inputs with float32 accumulation,
the same numbers on every backend (emulated exactly on a CPU), training always at the backend's default."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx.core import ensemble as ens
from poir_mjx.core.agent import POIR
from poir_mjx.core.config import MLPConfig
from tests.helpers import SMALL


def test_round_to_tf32_keeps_ten_mantissa_bits_ties_to_even():
    x = jax.random.normal(jax.random.PRNGKey(0), (10_000,)) * 100
    r = np.asarray(ens.round_to_tf32(x))
    bits = r.view(np.uint32)
    assert np.all(bits & 0x1FFF == 0)  # the 13 low mantissa bits are gone
    rel = np.abs(r - np.asarray(x)) / np.abs(np.asarray(x))
    assert rel.max() <= 2.0**-11 and rel.max() > 2.0**-13  # rounded to nearest, not truncated nor kept
    one = np.float32(1.0)
    half_ulp = np.float32(2.0**-11)  # exactly half a TF32 ulp above 1: a tie, to the even neighbour (1.0)
    assert float(ens.round_to_tf32(jnp.float32(one + half_ulp))) == 1.0
    three_halves = np.float32(1.0 + 3 * 2.0**-11)  # tie between 1 + 2^-10 (odd) and 1 + 2^-9 (even)
    assert float(ens.round_to_tf32(jnp.float32(three_halves))) == 1.0 + 2.0**-9


@pytest.mark.parametrize("matmul, round_fn", [("tf32", ens.round_to_tf32),
                                              ("bfloat16", lambda v: v.astype(jnp.bfloat16).astype(jnp.float32))])
def test_reduced_matmul_is_float32_arithmetic_on_rounded_inputs(matmul, round_fn):
    cfg = MLPConfig(layers=2, width=64)
    x = jax.random.normal(jax.random.PRNGKey(1), (32, 19))
    params = ens.make_mlp(cfg, 7).init(jax.random.PRNGKey(2), x)
    full = ens.make_mlp(cfg, 7, "float32").apply(params, x)
    low = ens.make_mlp(cfg, 7, matmul).apply(params, x)
    dense = params["params"]["Dense_0"], params["params"]["Dense_1"]
    hp = jax.lax.Precision.HIGHEST
    h = jax.nn.relu(jnp.dot(round_fn(x), round_fn(dense[0]["kernel"]), precision=hp) + dense[0]["bias"])
    emulated = jnp.dot(round_fn(h), round_fn(dense[1]["kernel"]), precision=hp) + dense[1]["bias"]
    np.testing.assert_allclose(low, emulated, rtol=1e-5, atol=1e-5)
    assert float(jnp.abs(low - full).max()) > 1e-4  # it changes the numbers (the default and float32 would not here)
    np.testing.assert_array_equal(ens.make_mlp(cfg, 7).apply(params, x), full)  # a CPU's default is true float32


def test_agents_act_with_the_setting_and_train_at_the_default():
    agent = POIR(dataclasses.replace(SMALL, planner=dataclasses.replace(SMALL.planner, matmul="bfloat16")), 5, 3)
    assert agent.bc_module.matmul == agent.wm_module.matmul == "bfloat16"
    assert [m.matmul for m in agent.train_modules] == ["default", "default"]
    assert POIR(SMALL, 5, 3).bc_module.matmul == "default"
