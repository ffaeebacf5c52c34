import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx.core.config import OnlineConfig
from poir_mjx.online import buffer as rb
from poir_mjx.online.finetune import online_fraction


def _rows(start, n):
    x = jnp.arange(start, start + n, dtype=jnp.float32)[:, None]
    return x, x + 0.5, x + 1.0


def test_ring_buffer_wraps_and_keeps_the_newest():
    buf = rb.init(5, 1, 1)
    o, a, o2 = _rows(0, 3)
    buf = rb.add(buf, o, a, o2, jnp.ones(3))
    assert int(buf.size) == 3 and int(buf.ptr) == 3
    o, a, o2 = _rows(3, 4)
    buf = rb.add(buf, o, a, o2, jnp.ones(4))
    assert int(buf.size) == 5 and int(buf.ptr) == 2
    # rows 0..6 written into 5 slots: slots 0, 1 now hold 5, 6 (the oldest 0, 1 were overwritten)
    np.testing.assert_array_equal(np.asarray(buf.obs[:, 0]), [5, 6, 2, 3, 4])
    np.testing.assert_array_equal(np.asarray(buf.next_obs[:, 0]), [6, 7, 3, 4, 5])


def test_ring_buffer_more_rows_than_capacity_and_invalid_rows():
    buf = rb.init(4, 1, 1)
    o, a, o2 = _rows(0, 6)
    valid = jnp.array([1, 1, 1, 1, 0, 1])
    buf = rb.add(buf, o, a, o2, valid)
    assert int(buf.size) == 4 and int(buf.ptr) == 0
    np.testing.assert_array_equal(np.asarray(buf.obs[:, 0]), [2, 3, 0, 5])  # row 4 invalid: zeroed
    np.testing.assert_array_equal(np.asarray(buf.valid), [1, 1, 0, 1])
    with pytest.raises(ValueError, match="buffer_capacity"):
        rb.init(0, 1, 1)


def test_mixing_schedule_is_the_papers():
    cfg = OnlineConfig()
    steps = np.array([0, 99, 100, 199, 200, 900, 999, 1000, 5000])
    got = np.asarray(online_fraction(cfg, jnp.asarray(steps)))
    np.testing.assert_allclose(got, [0.0, 0.0, 0.05, 0.05, 0.10, 0.45, 0.45, 0.5, 0.5], atol=1e-7)
