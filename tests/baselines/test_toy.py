"""The off-policy toy (tests/baselines/toy.py) needs learning: the expert solves it, a constant action does not."""

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.rollout.evaluator import make_evaluator
from tests.baselines import toy


def test_the_expert_solves_the_toy_and_a_constant_action_does_not():
    assert toy.expert_success_rate() == 1.0
    constant = make_evaluator(toy.ENV, lambda p, o, k: jnp.array([0.2, -toy.DRIFT]), toy.HORIZON)
    out = constant(None, jax.random.split(jax.random.PRNGKey(7), 32), toy.broadcast(toy.PARAMS, 32))
    assert np.mean(np.asarray(out["first_success"]) >= 0) < 0.3  # 6/32 when written: starts already in the band
    # success counts at the last step only
    assert np.all(np.asarray(out["first_success"])[np.asarray(out["first_success"]) >= 0] == toy.HORIZON)


def test_expert_data_layout():
    ex = toy.expert_data()
    assert ex.obs.shape == (16 * toy.HORIZON, 2) and ex.actions.shape == (16 * toy.HORIZON, 2)
    assert ex.terminal.sum() == 16 and ex.initial.sum() == 16
    np.testing.assert_allclose(ex.next_obs[:-1][~ex.terminal[:-1]], ex.obs[1:][~ex.terminal[:-1]])
