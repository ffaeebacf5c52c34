"""The one checkpoint file format: a msgpack mapping (flax.serialization) with a format tag, written atomically.

A file holds ``{"format": <tag>, <field>: ..., ...}``; fields are JSON strings (configs, records) or
pytrees stored as flax state dicts, i.e. nested mappings keyed by NAME (dataclass fields, dict keys,
``"0"``, ``"1"`` for tuple items). ``restore`` puts them back into a template of the expected
structure with ``flax.serialization.from_state_dict``, after checking every name, shape and dtype
against the template, so a reordered dataclass or dict loads each array into its own place and a
missing, extra or misshapen entry is a ``CheckpointError`` naming the file and the field's path.

Pytree node types flax does not know (e.g. MJX's ``Data`` inside an environment state that a baseline
checkpoints) are registered with flax on first use, keyed by their JAX key-path names (dataclass fields).

(flax rather than orbax: one file per checkpoint, synchronous, no extra dependency; orbax's
directory layout and async managers serve multi-host sharded arrays, which these small states are not.)
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any, Mapping

import jax
import numpy as np
from flax import serialization

from poir_mjx.atomic import atomic_write_bytes


class CheckpointError(ValueError):
    """A checkpoint is unreadable or does not match what it is loaded for; the message names file and field."""


def write(path: str | Path, fmt: str, fields: Mapping[str, Any]) -> Path:
    """Write ``{"format": fmt, **fields}`` atomically, wrapped with the sha256 of its bytes (verified by ``read``);
    pytree fields should come from ``state_dict``."""
    path = Path(path)
    payload = serialization.msgpack_serialize({"format": fmt, **fields})
    wrapped = {"format": fmt, "sha256": hashlib.sha256(payload).hexdigest(), "payload": payload}
    atomic_write_bytes(path, serialization.msgpack_serialize(wrapped))
    return path


def state_dict(tree: Any) -> Any:
    """A pytree as a name-keyed state dict with host (numpy) leaves, ready for ``write``."""
    tree = jax.tree_util.tree_map(np.asarray, tree)
    _register_unknown_nodes(tree)
    return serialization.to_state_dict(tree)


def _children(node: Any) -> tuple[list, Any]:
    """One level of `node`: [(name, child)] by JAX key path, and the treedef to rebuild it."""
    flat, treedef = jax.tree_util.tree_flatten_with_path(node, is_leaf=lambda x: x is not node)
    return [(_key_name(path[0]), child) for path, child in flat], treedef


def _key_name(key: Any) -> str:
    for attr in ("name", "key", "idx"):  # GetAttrKey, DictKey / FlattenedIndexKey, SequenceKey
        if hasattr(key, attr):
            return str(getattr(key, attr))
    return str(key)


def _node_to_state(node: Any) -> dict:
    return {name: serialization.to_state_dict(child) for name, child in _children(node)[0]}


def _node_from_state(node: Any, state: dict) -> Any:
    named, treedef = _children(node)
    return jax.tree_util.tree_unflatten(treedef, [serialization.from_state_dict(c, state[n]) for n, c in named])


def _register_unknown_nodes(tree: Any) -> None:
    """Register with flax every pytree node type in `tree` that it would otherwise store as a raw object."""
    if tree is None or jax.tree_util.treedef_is_leaf(jax.tree_util.tree_structure(tree)):
        return
    namedtuple = isinstance(tree, tuple) and hasattr(tree, "_fields")  # flax handles these as one kind
    if not (namedtuple or serialization.is_serializable(tree)):
        serialization.register_serialization_state(type(tree), _node_to_state, _node_from_state)
    for _, child in _children(tree)[0]:
        _register_unknown_nodes(child)


def read(path: str | Path, fmt: str, retired: Mapping[str, str] | None = None) -> dict:
    """The mapping stored in `path`, which must carry format `fmt`.

    retired: older format tags this reader refuses, each with the one-line advice to give.
    """
    path = Path(path)
    if path.is_dir():
        raise CheckpointError(f"{path}: is a directory, expected a checkpoint file")
    if not path.is_file():
        raise CheckpointError(f"{path}: no such checkpoint file")
    damaged = "; the file is damaged or truncated: delete it and it is made again"
    raw = path.read_bytes()
    if not raw or not (0x80 <= raw[0] <= 0x8F or raw[0] in (0xDE, 0xDF)):  # every checkpoint is a msgpack map
        start = raw[:1].decode("latin-1") if raw else "nothing"
        raise CheckpointError(f"{path}: not a poir-mjx checkpoint (it starts with {start!r}, a checkpoint with a "
                              "msgpack map); give a .ckpt file a sweep made")  # fmt: skip
    try:
        blob = serialization.msgpack_restore(raw)
    except Exception as e:
        raise CheckpointError(f"{path}: not a poir-mjx checkpoint ({type(e).__name__}: {e}){damaged}") from e
    checked = isinstance(blob, dict) and "payload" in blob
    if checked:  # checksummed (files written before it carry none: refused below)
        payload = blob["payload"]
        if not isinstance(payload, bytes) or hashlib.sha256(payload).hexdigest() != blob.get("sha256"):
            raise CheckpointError(f"{path}: field 'sha256' does not match the content{damaged}")
        try:
            blob = serialization.msgpack_restore(payload)
        except Exception as e:
            raise CheckpointError(f"{path}: not a poir-mjx checkpoint ({type(e).__name__}: {e}){damaged}") from e
    if not isinstance(blob, dict):
        raise CheckpointError(f"{path}: not a poir-mjx checkpoint (no field 'format')")
    got = blob.get("format")
    if retired and got in retired:
        raise CheckpointError(f"{path}: format {got!r}: {retired[got]}")
    if not checked:
        raise CheckpointError(f"{path}: written before checkpoints carried a sha256, so its content cannot be verified; "
                              "delete it and it is made again")  # fmt: skip
    if got != fmt:
        raise CheckpointError(f"{path}: field 'format' is {got!r}, expected {fmt!r}")
    return blob


def json_field(path: str | Path, blob: Mapping[str, Any], name: str) -> Any:
    """Field `name` of a checkpoint, stored as a JSON string, decoded."""
    if name not in blob:
        raise CheckpointError(f"{path}: field '{name}' is missing")
    try:
        return json.loads(blob[name])
    except (TypeError, json.JSONDecodeError) as e:
        raise CheckpointError(f"{path}: field '{name}' is not valid JSON ({e})") from e


def restore(path: str | Path, template: Any, blob: Mapping[str, Any], name: str, *, cast_floats: bool = False,
            finite: bool = False) -> Any:  # fmt: skip
    """Field `name` of a checkpoint put back into the structure of `template`, entry by entry by name.

    template: a pytree of arrays or ``jax.ShapeDtypeStruct`` (e.g. from ``jax.eval_shape``) giving
    every entry's name, shape and dtype. cast_floats: accept a stored floating array of another
    float dtype and cast it (e.g. float64 parameters into float32); otherwise dtypes must match. finite: every
    floating entry must be finite in the template's dtype (network weights: a NaN loads as a silent failure).
    Leaves come back as jax arrays of the template's dtypes.
    """
    if name not in blob:
        raise CheckpointError(f"{path}: field '{name}' is missing")
    _register_unknown_nodes(template)
    want = serialization.to_state_dict(template)
    checked = _check(str(path), want, blob[name], name, cast_floats, finite)
    return serialization.from_state_dict(template, checked)


def _check(path: str, want: Any, got: Any, where: str, cast_floats: bool, finite: bool = False) -> Any:
    """`got` validated against the state dict `want`; returns it with leaves as jax arrays of `want`'s dtypes."""
    if isinstance(want, dict):
        if not isinstance(got, dict):
            raise CheckpointError(f"{path}: field '{where}' is {_kind(got)}, expected a mapping")
        for k in want:
            if k not in got:
                raise CheckpointError(f"{path}: field '{where}.{k}' is missing")
        extra = sorted(set(got) - set(want))
        if extra:
            raise CheckpointError(f"{path}: field '{where}.{extra[0]}' is not expected here")
        return {k: _check(path, v, got[k], f"{where}.{k}", cast_floats, finite) for k, v in want.items()}
    if want is None:
        if got is not None:
            raise CheckpointError(f"{path}: field '{where}' is {_kind(got)}, expected none")
        return None
    if got is None or isinstance(got, dict):
        raise CheckpointError(f"{path}: field '{where}' is {_kind(got)}, expected an array")
    shape = tuple(np.shape(want))
    dtype = np.dtype(want.dtype if hasattr(want, "dtype") else np.asarray(want).dtype)
    x = np.asarray(got)
    if x.shape != shape:
        raise CheckpointError(f"{path}: field '{where}' has shape {x.shape}, expected {shape}")
    if x.dtype != dtype and not (cast_floats and _floating(x.dtype) and _floating(dtype)):
        raise CheckpointError(f"{path}: field '{where}' has dtype {x.dtype}, expected {dtype}")
    if finite and _floating(dtype):
        with np.errstate(over="ignore", invalid="ignore"):
            ok = np.isfinite(x.astype(dtype))
        if not ok.all():
            raise CheckpointError(f"{path}: field '{where}' holds NaN or inf (entry {np.argwhere(~ok)[0].tolist()}); "
                                  "the agent diverged or the file was edited: delete it and it is made again")  # fmt: skip
    return jax.numpy.asarray(x, dtype)


def _floating(dtype) -> bool:
    return np.issubdtype(dtype, np.floating)


def _kind(x: Any) -> str:
    if x is None:
        return "none"
    if isinstance(x, dict):
        return "a mapping"
    return f"an array of shape {np.shape(x)}"
