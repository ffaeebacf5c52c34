"""Resumable online runs: the whole run state (world-model parameters, optimiser state, replay buffer,
counters, RNG key) plus a JSON record (config hash, learning curve), written atomically.

Format: msgpack of {"format", "meta" (JSON), "leaves": {"0": array, ...}}; the leaves are those of
the run-state pytree in ``jax.tree_util`` order, restored into a template of the same structure.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import jax
import numpy as np
from flax import serialization

from poir_mjx.atomic import atomic_write_bytes
from poir_mjx.core.checkpoint import CheckpointError, read_blob

FORMAT = "poir-mjx-online/1"


def save(path: str | Path, state: Any, meta: dict) -> Path:
    path = Path(path)
    leaves = jax.tree_util.tree_leaves(state)
    blob = {
        "format": FORMAT,
        "meta": json.dumps(meta, sort_keys=True),
        "leaves": {str(i): np.asarray(x) for i, x in enumerate(leaves)},
    }
    atomic_write_bytes(path, serialization.msgpack_serialize(blob))
    return path


def load(path: str | Path, template: Any, config_hash: str) -> tuple[Any, dict]:
    """Restore a run state shaped like `template`; the checkpoint must carry `config_hash`."""
    path = Path(path)
    blob = read_blob(path, FORMAT)
    try:
        meta = json.loads(blob["meta"])
    except (KeyError, json.JSONDecodeError) as e:
        raise CheckpointError(f"{path}: field 'meta' is invalid ({e})") from e
    if meta.get("config_hash") != config_hash:
        raise CheckpointError(f"{path}: field 'config_hash' is {meta.get('config_hash')!r}, expected {config_hash!r}")
    leaves, treedef = jax.tree_util.tree_flatten(template)
    stored = blob.get("leaves", {})
    if len(stored) != len(leaves):
        raise CheckpointError(f"{path}: field 'leaves' has {len(stored)} arrays, the run state has {len(leaves)}")
    out = []
    for i, ref in enumerate(leaves):
        x = np.asarray(stored[str(i)])
        if x.shape != np.shape(ref):
            raise CheckpointError(f"{path}: field 'leaves.{i}' has shape {x.shape}, expected {np.shape(ref)}")
        out.append(jax.numpy.asarray(x, dtype=np.asarray(ref).dtype))
    return jax.tree_util.tree_unflatten(treedef, out), meta
