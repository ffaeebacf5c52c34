"""Stacked-parameter ensembles (poir_mjx/core/ensemble.py): vmap over members, training, independence."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx.core import ensemble as ens
from poir_mjx.core.config import MLPConfig, TrainConfig

K, D_IN, D_OUT = 3, 2, 1
MODULE = ens.make_mlp(MLPConfig(layers=2, width=16), D_OUT)


def _member(params, k):
    return jax.tree_util.tree_map(lambda p: p[k], params)


def test_stacked_parameters_apply_each_member_as_its_own_network():
    params = ens.init_ensemble(MODULE, jax.random.PRNGKey(0), K, D_IN)
    assert ens.ensemble_size(params) == K
    assert all(leaf.shape[0] == K and leaf.dtype == jnp.float32 for leaf in jax.tree_util.tree_leaves(params))
    x = jax.random.normal(jax.random.PRNGKey(1), (5, D_IN))
    out = ens.apply_all(MODULE, params, x)
    assert out.shape == (K, 5, D_OUT)
    xs = jax.random.normal(jax.random.PRNGKey(2), (K, 4, D_IN))
    each = ens.apply_each(MODULE, params, xs)
    for k in range(K):
        np.testing.assert_allclose(out[k], MODULE.apply(_member(params, k), x), rtol=1e-6)
        np.testing.assert_allclose(each[k], MODULE.apply(_member(params, k), xs[k]), rtol=1e-6)
    assert not np.allclose(out[0], out[1])  # independent initialisations


def test_training_lowers_every_members_loss_and_members_stay_different():
    x = jax.random.uniform(jax.random.PRNGKey(3), (128, D_IN), minval=-1, maxval=1)
    y = jnp.sin(2 * x[:, :1]) + 0.5 * x[:, 1:]
    cfg = TrainConfig(batch_size=32, learning_rate=1e-2)
    opt = ens.make_optimizer(cfg)
    state = ens.init_train_state(ens.init_ensemble(MODULE, jax.random.PRNGKey(4), K, D_IN), opt)
    before = np.asarray(ens.mse(MODULE, state.params, x, y))
    for e in range(30):
        state, loss = ens.train_epoch(MODULE, opt, cfg.batch_size, state, x, y, jax.random.PRNGKey(100 + e))
    after = np.asarray(ens.mse(MODULE, state.params, x, y))
    assert loss.shape == (K,)
    assert np.all(after < 0.2 * before), (before, after)
    np.testing.assert_allclose(after, np.mean((np.asarray(ens.apply_all(MODULE, state.params, x)) - np.asarray(y)) ** 2,
                                              axis=(1, 2)), rtol=1e-5)  # fmt: skip
    preds = np.asarray(ens.apply_all(MODULE, state.params, jnp.array([[2.0, 2.0]])))  # outside the data
    assert np.ptp(preds) > 1e-3, preds  # the members disagree where they saw no data


def test_a_batch_larger_than_the_data_is_refused():
    opt = ens.make_optimizer(TrainConfig())
    state = ens.init_train_state(ens.init_ensemble(MODULE, jax.random.PRNGKey(0), K, D_IN), opt)
    with pytest.raises(ValueError, match="batch_size: 64 exceeds the number of training samples 10"):
        ens.train_epoch(MODULE, opt, 64, state, jnp.zeros((10, D_IN)), jnp.zeros((10, D_OUT)), jax.random.PRNGKey(0))


def test_training_runs_share_one_compiled_epoch():
    """A fresh fit with the same config and shapes reuses the compiled epoch (one optimizer object per config)."""
    from poir_mjx.core.agent import POIR
    from poir_mjx.core.config import MLPConfig, POIRConfig
    from tests.helpers import expert_data

    cfg = POIRConfig(ensemble_size=2, bc=MLPConfig(layers=2, width=8), world_model=MLPConfig(layers=2, width=8),
                     train=TrainConfig(epochs=1, batch_size=32, learning_rate=2e-3))  # fmt: skip
    data = expert_data(n_demos=4, steps=10)
    POIR(cfg, 2, 2).fit(jax.random.PRNGKey(0), *data)
    compiled = ens.train_epoch._cache_size()
    POIR(cfg, 2, 2).fit(jax.random.PRNGKey(1), *data)
    assert ens.train_epoch._cache_size() == compiled
