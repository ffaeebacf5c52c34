"""The device replay (poir_mjx/baselines/replay.py): circular rows, n-step windows, n-step targets, expert stores."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx.baselines import replay as rp

GAMMA = 0.9


def _store(rows=6, envs=2, writes=8, end_every=3, invalid=()):
    """obs = [write index, env]; an episode ends every `end_every` writes; `invalid` (write, env) pairs."""
    buf = rp.init(rows * envs, envs, 2, 1)
    for i in range(writes):
        obs = jnp.array([[i, e] for e in range(envs)], jnp.float32)
        valid = jnp.array([(i, e) not in invalid for e in range(envs)])
        end = jnp.full(envs, (i + 1) % end_every == 0)
        buf = rp.add(buf, obs, jnp.ones((envs, 1)) * i, obs + 0.5, end, valid)
    return buf


def test_rows_wrap_around():
    buf = _store(rows=6, writes=8)
    assert int(buf.size) == 6 and int(buf.ptr) == 2
    np.testing.assert_array_equal(buf.obs[:, 0, 0], [6, 7, 2, 3, 4, 5])  # writes 6 and 7 replaced 0 and 1
    with pytest.raises(ValueError, match="replay_capacity"):
        rp.init(1, 2, 2, 1)


def test_windows_stop_at_episode_ends_invalid_rows_and_the_newest_row():
    writes, invalid = 8, {(4, 1)}
    buf = _store(rows=6, writes=writes, end_every=3, invalid=invalid)
    w = rp.sample_windows(buf, jax.random.PRNGKey(0), 512, 4)
    t0, e0 = np.asarray(w.obs[:, 0, 0]).astype(int), np.asarray(w.obs[:, 0, 1]).astype(int)
    live, weight = np.asarray(w.live), np.asarray(w.weight)
    assert set(t0[weight > 0]) == {2, 3, 4, 5, 6, 7}  # only the rows still held (writes 2..7)
    for b in range(512):
        if (t0[b], e0[b]) in invalid or weight[b] == 0:
            assert weight[b] == 0 and not live[b].any()
            continue
        expect = [True]
        for k in range(1, 4):
            t = t0[b] + k
            # write t - 1 ended its episode when t is a multiple of 3; write t must exist and be valid
            ok = expect[-1] and t % 3 != 0 and t < writes and (t, e0[b]) not in invalid
            expect.append(ok)
        np.testing.assert_array_equal(live[b], expect, err_msg=f"start {t0[b]}, env {e0[b]}")
        n_live = sum(expect)
        np.testing.assert_array_equal(np.asarray(w.obs[b, :n_live, 0]), t0[b] + np.arange(n_live))  # in time order
        assert np.all(np.asarray(w.obs[b, :n_live, 1]) == e0[b])  # one environment


def test_invalid_rows_are_stored_as_zeros_and_end_their_episode():
    buf = _store(rows=6, writes=5, invalid={(4, 1)})
    assert not bool(buf.valid[4, 1]) and bool(buf.end[4, 1])
    np.testing.assert_array_equal(buf.obs[4, 1], 0.0)


def test_nstep_return():
    r = jnp.array([[1.0, 2.0, 4.0], [1.0, 2.0, 4.0], [1.0, 2.0, 4.0]])
    live = jnp.array([[True, True, True], [True, True, False], [True, True, False]])
    term = jnp.array([[False] * 3, [False, True, False], [False] * 3])
    ret, disc, last = rp.nstep_return(r, live, term, GAMMA)
    np.testing.assert_allclose(ret, [1 + 2 * GAMMA + 4 * GAMMA**2, 1 + 2 * GAMMA, 1 + 2 * GAMMA], rtol=1e-6)
    np.testing.assert_allclose(disc, [GAMMA**3, 0.0, GAMMA**2], rtol=1e-6)
    np.testing.assert_array_equal(last, [2, 1, 1])
    x = jnp.arange(3 * 3 * 2).reshape(3, 3, 2)
    np.testing.assert_array_equal(rp.at_last(x, last), x[jnp.arange(3), last])


def test_expert_store_splits_demonstrations():
    # two demos of 3 steps along a line, then one row that does not start where the previous ended
    obs = np.array([[0.0], [1.0], [2.0], [10.0], [11.0], [12.0], [50.0]], np.float32)
    nxt = obs + 1
    demo_end = np.array([False, False, True, False, False, False, True])
    buf = rp.from_expert(obs, np.zeros((7, 1)), nxt, demo_end, terminal=demo_end)
    np.testing.assert_array_equal(buf.end[:, 0], [False, False, True, False, False, True, True])
    np.testing.assert_array_equal(buf.terminal[:, 0], demo_end)
    w = rp.sample_windows(buf, jax.random.PRNGKey(1), 256, 3)
    starts = np.asarray(w.obs[:, 0, 0])
    n_live = np.asarray(w.live.sum(1))
    expect = {0.0: 3, 1.0: 2, 2.0: 1, 10.0: 3, 11.0: 2, 12.0: 1, 50.0: 1}
    assert all(n_live[i] == expect[float(s)] for i, s in enumerate(starts))
    assert np.all(np.asarray(w.weight) == 1.0)
    assert not bool(rp.from_expert(obs, np.zeros((7, 1)), nxt, demo_end).terminal.any())  # truncations by default
