import numpy as np
import pytest
from scipy.stats import spearmanr

from poir_mjx.diagnose import call_stats as cs


def test_real_rows_follow_the_planners_trajectory_order():
    k, m, n = 3, 4, 10
    grid = np.arange(k)[:, None] + k * np.arange(m)[None, :]  # trajectory n sits at [n mod K, n // K]
    np.testing.assert_array_equal(cs.real_rows(grid, n), np.arange(n))
    np.testing.assert_array_equal(cs.real_heads(k, n), np.arange(n) % k)


def test_between_head_share_is_one_when_the_head_decides_and_near_zero_when_not():
    heads = cs.real_heads(4, 400)
    assert cs.between_head_share(heads * 1.5, heads) == pytest.approx(1.0)
    noise = np.random.default_rng(0).normal(size=400)
    assert cs.between_head_share(noise, heads) < 0.05
    assert cs.between_head_share(np.ones(400), heads) == 0.0


def test_top_k_head_histogram_and_overlap():
    ret = np.array([0.0, 9.0, 1.0, 8.0, 2.0, 7.0])
    heads = cs.real_heads(2, 6)
    top = cs.top_k_indices(ret, 3)
    np.testing.assert_array_equal(top, [1, 3, 5])
    np.testing.assert_array_equal(cs.head_histogram(top, heads, 2), [0, 3])  # all three from head 1
    assert cs.top_k_overlap(ret, ret, 3) == 1.0 and cs.top_k_overlap(ret, -ret, 3) == 0.0
    assert cs.top_k_indices(np.array([np.nan, 1.0, 0.0]), 1)[0] == 1  # NaN ranks last, as the planner ranks it


def test_spearman_matches_scipy_with_ties():
    rng = np.random.default_rng(1)
    x, y = rng.integers(0, 5, 50).astype(float), rng.normal(size=50)
    assert cs.spearman(x, y) == pytest.approx(spearmanr(x, y).statistic)
    assert np.isnan(cs.spearman(np.ones(5), y[:5]))


def test_within_head_spearman_ignores_which_head():
    heads = cs.real_heads(3, 60)
    rng = np.random.default_rng(0)
    noise = rng.normal(size=60)
    model = 10.0 * heads + noise  # the head decides the overall order
    same_noise = -10.0 * heads + noise  # the true returns order the heads the other way, the noise the same way
    assert cs.spearman(model, same_noise) < -0.5 and cs.within_head_spearman(model, same_noise, heads) == pytest.approx(1)
    other_noise = 10.0 * heads + rng.normal(size=60)  # right about the heads, blind within them
    assert cs.spearman(model, other_noise) > 0.8 and abs(cs.within_head_spearman(model, other_noise, heads)) < 0.4
    assert np.isnan(cs.within_head_spearman(np.ones(6), noise[:6], cs.real_heads(3, 6)))


def test_max_pair_difference_and_dimension_shares():
    # three members in 2-D: the most distant pair is (0, 2), differing only in the second dimension
    x = np.array([[[0.0, 0.0]], [[0.0, 1.0]], [[0.0, 3.0]]])
    d = cs.max_pair_difference(x)
    np.testing.assert_allclose(np.abs(d), [[0.0, 3.0]])
    np.testing.assert_allclose(cs.dimension_shares(np.array([[3.0, 4.0], [0.0, 0.0]])), [9 / 25, 16 / 25])
    np.testing.assert_array_equal(cs.dimension_shares(np.zeros((2, 3))), np.zeros(3))

