"""The checkpoint codec: atomic writes, the format tag, restoring by name with every entry checked."""

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from flax import serialization, struct

from poir_mjx import checkpoint_codec as codec
from poir_mjx.checkpoint_codec import CheckpointError

FMT = "test-codec/1"


@struct.dataclass
class Pair:
    a: jnp.ndarray
    b: jnp.ndarray


@struct.dataclass
class PairSwapped:  # the same names, declared in the other order (positional restoring would swap them)
    b: jnp.ndarray
    a: jnp.ndarray


def _save(path, tree):
    return codec.write(path, FMT, {"tree": codec.state_dict(tree), "note": '{"x": 1}'})


def _load(path, template, **kw):
    return codec.restore(path, template, codec.read(path, FMT), "tree", **kw)


def test_reordered_dataclass_and_dict_restore_each_array_by_name(tmp_path):
    saved = Pair(a=jnp.arange(3.0), b=jnp.arange(4, dtype=jnp.int32))
    path = _save(tmp_path / "pair.ckpt", saved)
    assert not list(tmp_path.glob(".*.tmp"))  # the atomic write left no temporary file
    back = _load(path, PairSwapped(b=jnp.zeros(4, jnp.int32), a=jnp.zeros(3)))
    assert isinstance(back, PairSwapped)
    np.testing.assert_array_equal(back.a, [0.0, 1.0, 2.0])
    np.testing.assert_array_equal(back.b, [0, 1, 2, 3])
    assert back.b.dtype == jnp.int32
    # a dict whose keys were inserted in another order
    path = _save(tmp_path / "dict.ckpt", {"x": jnp.ones(2), "y": jnp.zeros((2, 2))})
    back = _load(path, {"y": jnp.ones((2, 2)), "x": jnp.zeros(2)})
    np.testing.assert_array_equal(back["x"], [1.0, 1.0])
    np.testing.assert_array_equal(back["y"], np.zeros((2, 2)))
    assert codec.json_field(path, codec.read(path, FMT), "note") == {"x": 1}


@functools.partial(jax.tree_util.register_dataclass, data_fields=["x", "y"], meta_fields=["tag"])
@dataclasses.dataclass
class JaxOnlyNode:  # a pytree node jax knows and flax does not (as MJX's Data is)
    x: jnp.ndarray
    y: jnp.ndarray | None
    tag: str


def test_pytree_nodes_flax_does_not_know_restore_by_field_name(tmp_path):
    """An environment state with MJX's Data inside (a baseline's checkpoint) stores field names, not objects."""
    import mujoco
    from mujoco import mjx

    model = mjx.put_model(mujoco.MjModel.from_xml_string("<mujoco><worldbody><body><freejoint/>"
                                                         "<geom size='0.1'/></body></worldbody></mujoco>"))  # fmt: skip
    data = mjx.make_data(model)
    saved = {"env": (JaxOnlyNode(jnp.arange(3.0), None, "a"), data.replace(qpos=data.qpos + 1.0))}
    stored = codec.state_dict(saved)
    assert set(stored["env"]["0"]) == {"x", "y"} and "qpos" in stored["env"]["1"]
    path = _save(tmp_path / "env.ckpt", saved)
    template = {"env": (JaxOnlyNode(jnp.zeros(3), None, "a"), data)}
    back = _load(path, template)
    assert isinstance(back["env"][0], JaxOnlyNode) and back["env"][0].tag == "a" and back["env"][0].y is None
    np.testing.assert_array_equal(back["env"][0].x, [0.0, 1.0, 2.0])
    assert isinstance(back["env"][1], type(data))
    np.testing.assert_array_equal(back["env"][1].qpos, np.asarray(data.qpos) + 1.0)


TEMPLATE = {"net": {"w": jnp.zeros((2, 3)), "b": jnp.zeros(3)}, "step": jnp.zeros((), jnp.int32)}


@pytest.mark.parametrize("stored, message", [
    ({"net": {"w": np.zeros((2, 3), np.float32)}, "step": np.int32(0)}, r"bad\.ckpt: field 'tree\.net\.b' is missing"),
    ({"net": {"w": np.zeros((2, 3), np.float32), "b": np.zeros(3, np.float32), "c": np.zeros(1)},
      "step": np.int32(0)}, r"bad\.ckpt: field 'tree\.net\.c' is not expected"),
    ({"net": {"w": np.zeros((3, 2), np.float32), "b": np.zeros(3, np.float32)}, "step": np.int32(0)},
     r"bad\.ckpt: field 'tree\.net\.w' has shape \(3, 2\), expected \(2, 3\)"),
    ({"net": {"w": np.zeros((2, 3), np.float32), "b": np.zeros(3, np.float32)}, "step": np.float32(0)},
     r"bad\.ckpt: field 'tree\.step' has dtype float32, expected int32"),
    ({"net": np.zeros(3, np.float32), "step": np.int32(0)},
     r"bad\.ckpt: field 'tree\.net' is an array .*expected a mapping"),
])  # fmt: skip
def test_missing_extra_or_misshapen_entries_name_file_and_field(tmp_path, stored, message):
    path = codec.write(tmp_path / "bad.ckpt", FMT, {"tree": stored})
    with pytest.raises(CheckpointError, match=message) as e:
        _load(path, TEMPLATE)
    assert "\n" not in str(e.value)


def test_float_dtypes_cast_only_when_asked(tmp_path):
    path = _save(tmp_path / "f64.ckpt", {"w": np.arange(3, dtype=np.float64)})
    with pytest.raises(CheckpointError, match="field 'tree.w' has dtype float64, expected float32"):
        _load(path, {"w": jnp.zeros(3, jnp.float32)})
    back = _load(path, {"w": jnp.zeros(3, jnp.float32)}, cast_floats=True)
    assert back["w"].dtype == jnp.float32 and back["w"].tolist() == [0.0, 1.0, 2.0]


def test_format_tag_and_unreadable_files(tmp_path):
    path = _save(tmp_path / "a.ckpt", {"w": np.zeros(1)})
    with pytest.raises(CheckpointError, match=r"a\.ckpt: field 'format' is 'test-codec/1', expected 'other/1'"):
        codec.read(path, "other/1")
    with pytest.raises(CheckpointError, match=r"a\.ckpt: format 'test-codec/1': delete it"):
        codec.read(path, "test-codec/2", retired={FMT: "delete it"})
    with pytest.raises(CheckpointError, match=r"a\.ckpt: field 'missing' is missing"):
        codec.restore(path, {}, codec.read(path, FMT), "missing")
    (tmp_path / "junk.ckpt").write_bytes(b"\x00not msgpack")
    with pytest.raises(CheckpointError, match=r"junk\.ckpt: not a poir-mjx checkpoint"):
        codec.read(tmp_path / "junk.ckpt", FMT)
    (tmp_path / "list.ckpt").write_bytes(serialization.msgpack_serialize([1, 2]))
    with pytest.raises(CheckpointError, match=r"list\.ckpt: not a poir-mjx checkpoint"):
        codec.read(tmp_path / "list.ckpt", FMT)
    with pytest.raises(CheckpointError, match="no such checkpoint file"):
        codec.read(tmp_path / "none.ckpt", FMT)
    with pytest.raises(CheckpointError, match="is a directory"):
        codec.read(tmp_path, FMT)


def test_a_damaged_file_is_refused_by_its_checksum(tmp_path):
    """64 bytes flipped mid-file (they once loaded silently as expert states up to 3.8e17) or a truncated file."""
    import numpy as np

    from poir_mjx import checkpoint_codec as codec

    path = codec.write(tmp_path / "c.ckpt", "t/1", {"x": codec.state_dict({"a": np.arange(4096, dtype=np.float32)})})
    assert codec.read(path, "t/1")["format"] == "t/1"
    raw = bytearray(path.read_bytes())
    mid = len(raw) // 2
    raw[mid : mid + 64] = bytes(b ^ 0xFF for b in raw[mid : mid + 64])
    path.write_bytes(bytes(raw))
    with pytest.raises(codec.CheckpointError, match="field 'sha256' does not match the content; the file is damaged"):
        codec.read(path, "t/1")
    path.write_bytes(bytes(raw[: len(raw) // 3]))
    with pytest.raises(codec.CheckpointError, match="delete it and it is made again"):
        codec.read(path, "t/1")
