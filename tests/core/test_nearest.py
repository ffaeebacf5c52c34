import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.core import nearest


def trajectories(rng, demos=40, steps=60, dims=6):
    """Expert states as smooth paths (a random walk per demo), like a demo file's."""
    walk = np.cumsum(rng.normal(size=(demos, steps, dims)) * 0.05, 1) + rng.normal(size=(demos, 1, dims))
    return walk.reshape(-1, dims).astype(np.float32)


def truth(q, e):
    return ((q[:, None, :].astype(np.float64) - e[None].astype(np.float64)) ** 2).sum(-1).min(1)


def test_the_shortlist_certifies_clustered_queries_without_the_scan():
    """One planner call's queries (imagined states of one start) lie together: the shortlist answers them exactly and
    measures a small part of the expert states."""
    rng = np.random.default_rng(0)
    e = trajectories(rng)
    for start in (0, 700, 2399):
        for spread in (0.0, 0.01, 0.03):
            q = (e[start] + rng.normal(size=(50, e.shape[1])) * spread).astype(np.float32)
            best, stats = nearest.search(jnp.asarray(q), jnp.asarray(e), size=512, block=64)
            np.testing.assert_allclose(best, truth(q, e), rtol=1e-5, atol=1e-7)
            assert int(stats["scanned"]) == 0 and float(stats["shortlist"]) <= 512 < e.shape[0]


def test_groups_far_apart_each_get_their_own_shortlist():
    """Two heads' imagined states far apart: one shortlist around their common centre certifies nothing, one per
    group certifies every query."""
    rng = np.random.default_rng(6)
    e = trajectories(rng)
    q = np.concatenate([e[10] + rng.normal(size=(20, 6)) * 0.01, e[2000] + rng.normal(size=(20, 6)) * 0.01])
    q = jnp.asarray(q, jnp.float32)
    one, stats_one = nearest.search(q, jnp.asarray(e), size=32, groups=1)
    two, stats_two = nearest.search(q, jnp.asarray(e), size=32, groups=2)
    assert int(stats_two["scanned"]) == 0 < int(stats_one["scanned"])
    np.testing.assert_allclose(one, two, rtol=1e-6)
    np.testing.assert_allclose(two, truth(np.asarray(q), e), rtol=1e-5, atol=1e-7)


def test_queries_the_shortlist_cannot_certify_are_scanned_against_every_expert_state():
    rng = np.random.default_rng(1)
    e = trajectories(rng)
    q = rng.normal(size=(30, e.shape[1])).astype(np.float32) * 3.0  # scattered far and wide: no common neighbourhood
    best, stats = nearest.search(jnp.asarray(q), jnp.asarray(e), size=64, block=32, spill=7)
    assert 0 < int(stats["scanned"]) <= 30
    np.testing.assert_allclose(best, truth(q, e), rtol=1e-5, atol=1e-7)


def test_the_shortlist_gives_the_scans_distances_under_vmap():
    """Episodes batched by vmap: some certified, some not; every one gets the scan's answer, whatever the others need."""
    rng = np.random.default_rng(2)
    e = jnp.asarray(trajectories(rng, demos=23, steps=57))  # 1311 states: no multiple of the block or the chunk
    starts = e[jnp.asarray([3, 500, 1300, 901])]
    spread = jnp.asarray([0.0, 0.02, 2.0, 0.05])[:, None, None]
    q = starts[:, None, :] + spread * jax.random.normal(jax.random.PRNGKey(0), (4, 40, e.shape[1]))
    got = jax.jit(jax.vmap(lambda x: nearest.search(x, e, 300, chunk=256, groups=2, block=100, spill=8)[0]))(q)
    want = jax.vmap(lambda x: nearest.scan(x, e, 256))(q)
    np.testing.assert_allclose(got, want, rtol=1e-6)  # the same sum of squares, perhaps summed in another order


def test_a_shortlist_as_large_as_the_data_is_the_scan():
    rng = np.random.default_rng(3)
    e, q = jnp.asarray(trajectories(rng, demos=3, steps=10)), jnp.asarray(rng.normal(size=(7, 6)), jnp.float32)
    for size in (0, 30, 4096):
        best, stats = nearest.search(q, e, size)
        assert int(stats["scanned"]) == 7
        np.testing.assert_array_equal(best, nearest.scan(q, e))


def test_expert_states_themselves_are_at_distance_zero():
    e = jnp.asarray(trajectories(np.random.default_rng(4)))
    np.testing.assert_array_equal(nearest.shortlisted(e[100:140], e, 256), 0.0)


def test_a_diverged_query_leaves_the_others_exact():
    """A NaN query moves the queries' centre to NaN: nothing is certified, the scan answers every query."""
    e = jnp.asarray(trajectories(np.random.default_rng(5)))
    q = (e[300:310] + 0.01).at[4].set(jnp.nan)
    got, want = nearest.shortlisted(q, e, 256), nearest.scan(q, e)
    np.testing.assert_allclose(got, want, rtol=1e-6)
    assert np.isnan(got[4]) and np.isfinite(np.delete(np.asarray(got), 4)).all()
