"""Resumable online runs: the whole run state (world-model parameters, optimiser state, replay buffer,
counters, RNG key) plus a JSON record (config hash, learning curve), written atomically.

Format (``poir_mjx.checkpoint_codec``): {"format", "meta" (JSON), "state" (the run state's state
dict, keyed by name)}, restored by name into a template of the run state (the freshly initialised
one), every entry's shape and dtype checked. Files of the first format, which stored the leaves by
their position in the pytree, are refused with the advice to delete them (the run then restarts).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from poir_mjx import checkpoint_codec as codec
from poir_mjx.checkpoint_codec import CheckpointError

FORMAT = "poir-mjx-online/2"
RETIRED = {"poir-mjx-online/1": "an online run state stored by position, no longer read; "
                                "delete this file and the run restarts from its first round"}  # fmt: skip


def save(path: str | Path, state: Any, meta: dict) -> Path:
    return codec.write(path, FORMAT, {"meta": json.dumps(meta, sort_keys=True), "state": codec.state_dict(state)})


def load(path: str | Path, template: Any, config_hash: str) -> tuple[Any, dict]:
    """Restore a run state shaped like `template`; the checkpoint must carry `config_hash`."""
    path = Path(path)
    blob = codec.read(path, FORMAT, RETIRED)
    meta = codec.json_field(path, blob, "meta")
    if not isinstance(meta, dict) or meta.get("config_hash") != config_hash:
        got = meta.get("config_hash") if isinstance(meta, dict) else None
        raise CheckpointError(f"{path}: field 'config_hash' is {got!r}, expected {config_hash!r}")
    return codec.restore(path, template, blob, "state"), meta
