import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.core import rewards


def np_l2(q, e):
    return -np.sqrt(((q[:, None, :] - e[None, :, :]) ** 2).sum(-1)).min(1)


def np_disagreement(x):
    k = x.shape[0]
    best = np.zeros(x.shape[1:-1])
    for i in range(k):
        for j in range(k):
            best = np.maximum(best, np.sqrt(((x[i] - x[j]) ** 2).sum(-1)))
    return -best


def test_l2_matches_numpy_for_any_chunking():
    rng = np.random.default_rng(0)
    q, e = rng.normal(size=(37, 5)).astype(np.float32), rng.normal(size=(101, 5)).astype(np.float32)
    for chunk in (1, 7, 100, 101, 4096):
        np.testing.assert_allclose(rewards.l2_reward(jnp.asarray(q), jnp.asarray(e), chunk), np_l2(q, e), rtol=1e-4, atol=1e-4)


def test_l2_is_zero_on_expert_states():
    e = jnp.asarray(np.random.default_rng(1).normal(size=(20, 3)) * 4.0, jnp.float32)
    np.testing.assert_array_equal(rewards.l2_reward(e[:5], e, 8), 0.0)


def test_l2_is_exact_near_the_data():
    """The expansion |s|^2 - 2 s.e + |e|^2 cancels near the data (float32: ~5e-3 of error at |e| ~ 13);
    the nearest candidates are re-measured directly, so near-expert states rank by their true distance."""
    rng = np.random.default_rng(5)
    e = (rng.normal(size=(3000, 20)) * 3.0).astype(np.float32)
    q = (e[:200] + rng.normal(size=(200, 20)) * np.geomspace(1e-5, 1e-1, 200)[:, None]).astype(np.float32)
    truth = np_l2(q.astype(np.float64), e.astype(np.float64))
    for chunk, refine in ((512, 8), (4096, 8), (4096, 1)):
        got = np.asarray(rewards.l2_reward(jnp.asarray(q), jnp.asarray(e), chunk, refine))
        np.testing.assert_allclose(got, truth, rtol=1e-3, atol=1e-6)


def test_dril_and_morel_match_numpy():
    rng = np.random.default_rng(2)
    a = rng.normal(size=(4, 6, 3)).astype(np.float32)  # K=4 heads, 6 queries, 3 dims
    np.testing.assert_allclose(rewards.dril_reward(jnp.asarray(a)), np_disagreement(a), rtol=1e-5)
    p = rng.normal(size=(3, 2, 5, 4)).astype(np.float32)  # K=3, batch dims (2, 5)
    np.testing.assert_allclose(rewards.morel_reward(jnp.asarray(p)), np_disagreement(p), rtol=1e-5)


def test_identical_heads_have_zero_disagreement():
    a = jnp.ones((5, 7, 2))
    np.testing.assert_array_equal(rewards.dril_reward(a), 0.0)


def test_approximate_subset_is_an_upper_bound_on_distance():
    rng = np.random.default_rng(3)
    q, e = rng.normal(size=(10, 4)).astype(np.float32), rng.normal(size=(500, 4)).astype(np.float32)
    sub = rewards.approximate_subset(jnp.asarray(e), 50, jax.random.PRNGKey(0))
    assert sub.shape == (50, 4)
    assert np.all(np.asarray(rewards.l2_reward(jnp.asarray(q), sub)) <= np_l2(q, e) + 1e-5)
