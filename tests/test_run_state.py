"""Online run-state checkpoints: restored by name into the run state, retired positional files refused."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from flax import serialization, struct

from poir_mjx.atomic import atomic_write_bytes
from poir_mjx.checkpoint_codec import CheckpointError
from poir_mjx.core import ensemble as ens
from poir_mjx.core.config import MLPConfig, TrainConfig
from poir_mjx.online import buffer as rb
from poir_mjx import run_state as ock
from poir_mjx.online.loop import RunState


@struct.dataclass
class ReorderedRunState:  # RunState's fields in another order: a positional format would mix them up
    round: jax.Array
    key: jax.Array
    buffer: rb.ReplayBuffer
    wm: ens.TrainState


def _state(seed: int) -> RunState:
    wm = ens.init_ensemble(ens.make_mlp(MLPConfig(layers=2, width=4), 3), jax.random.PRNGKey(seed), 2, 5)
    buf = rb.init(6, 3, 2)
    buf = rb.add(buf, *(jnp.full((2, n), seed + 1.0) for n in (3, 2, 3)), jnp.ones(2))
    opt = ens.make_optimizer(TrainConfig())
    return RunState(wm=ens.init_train_state(wm, opt), buffer=buf, key=jax.random.PRNGKey(seed + 7),
                    round=jnp.asarray(seed, jnp.int32))  # fmt: skip


def test_run_state_restores_by_name_into_a_reordered_structure(tmp_path):
    saved = _state(3)
    path = ock.save(tmp_path / "online.ckpt", saved, {"config_hash": "h", "curve": [1], "rounds": []})
    fresh = _state(0)
    template = ReorderedRunState(round=fresh.round, key=fresh.key, buffer=fresh.buffer, wm=fresh.wm)
    back, meta = ock.load(path, template, "h")
    assert isinstance(back, ReorderedRunState) and meta["curve"] == [1]
    for name in ("round", "key", "buffer", "wm"):
        want, got = getattr(saved, name), getattr(back, name)
        assert jax.tree_util.tree_structure(want) == jax.tree_util.tree_structure(got), name
        for x, y in zip(jax.tree_util.tree_leaves(want), jax.tree_util.tree_leaves(got)):
            assert x.dtype == y.dtype
            np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    assert int(back.round) == 3 and int(back.buffer.size) == 2


def test_other_run_shapes_and_retired_files_are_refused_with_one_line(tmp_path):
    path = ock.save(tmp_path / "online.ckpt", _state(1), {"config_hash": "h", "curve": [], "rounds": []})
    small = _state(1).replace(buffer=rb.init(4, 3, 2))
    shape_error = r"online\.ckpt: field 'state\.buffer\.obs' has shape \(6, 3\), expected \(4, 3\)"
    with pytest.raises(CheckpointError, match=shape_error):
        ock.load(path, small, "h")
    old = tmp_path / "old.ckpt"
    atomic_write_bytes(old, serialization.msgpack_serialize(
        {"format": "poir-mjx-online/1", "meta": '{"config_hash": "h"}', "leaves": {"0": np.zeros(2)}}))
    with pytest.raises(CheckpointError, match=r"old\.ckpt: .*stored by position.*delete this file") as e:
        ock.load(old, _state(0), "h")
    assert "\n" not in str(e.value)
