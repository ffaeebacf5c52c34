"""Checkpoints: parameters, normalisation statistics, the config and the observation layout, in one file.

Format: msgpack (flax.serialization) of {"format", "config" (JSON), "layout" (JSON), "params"}.
Writes go to a temporary file in the same folder, then an atomic rename. Loaded parameters are float32.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import jax
import numpy as np
from flax import serialization

from poir_mjx.atomic import atomic_write_bytes
from poir_mjx.core.agent import POIR, POIRParams
from poir_mjx.core.config import ConfigError, POIRConfig, from_dict, to_dict
from poir_mjx.core.normalizer import Normalizer

FORMAT = "poir-mjx-checkpoint/1"


class CheckpointError(ValueError):
    """A checkpoint is unreadable or does not match what it is loaded for; the message names file and field."""


def save(path: str | Path, agent: POIR, params: POIRParams, layout: dict[str, Any]) -> Path:
    """Write a checkpoint atomically. `layout` describes the observations (keys, sizes, task, data provenance)."""
    path = Path(path)
    state = {
        "format": FORMAT,
        "config": json.dumps(to_dict(agent.config), sort_keys=True),
        "layout": json.dumps({**layout, "obs_size": agent.obs_size, "act_size": agent.act_size}, sort_keys=True),
        "params": serialization.to_state_dict(jax.tree_util.tree_map(np.asarray, _plain(params))),
    }
    atomic_write_bytes(path, serialization.msgpack_serialize(state))
    return path


def _plain(params: POIRParams) -> dict:
    return {
        "bc": params.bc,
        "wm": params.wm,
        "reward_wm": params.reward_wm,
        "obs_norm": {"mean": params.obs_norm.mean, "std": params.obs_norm.std},
        "act_norm": {"mean": params.act_norm.mean, "std": params.act_norm.std},
        "expert_states": params.expert_states,
    }


def read_blob(path: Path, fmt: str = FORMAT) -> dict:
    """The msgpack mapping stored in `path`, which must carry format `fmt`; errors name the file and field."""
    if path.is_dir():
        raise CheckpointError(f"{path}: is a directory, expected a checkpoint file")
    if not path.is_file():
        raise CheckpointError(f"{path}: no such checkpoint file")
    try:
        state = serialization.msgpack_restore(path.read_bytes())
    except Exception as e:
        raise CheckpointError(f"{path}: not a poir-mjx checkpoint ({type(e).__name__}: {e})") from e
    if not isinstance(state, dict) or state.get("format") != fmt:
        raise CheckpointError(f"{path}: field 'format' is not {fmt!r}")
    return state


def read(path: str | Path) -> tuple[POIRConfig, dict, dict]:
    """(config, layout, raw params) of a checkpoint file, with clear errors."""
    path = Path(path)
    state = read_blob(path)
    try:
        config = from_dict(json.loads(state["config"]), POIRConfig, source=f"{path}: config")
    except (ConfigError, KeyError, json.JSONDecodeError) as e:
        raise CheckpointError(f"{path}: field 'config' is invalid ({e})") from e
    layout = json.loads(state["layout"])
    return config, layout, state["params"]


def load(path: str | Path, config: POIRConfig | None = None, layout: dict | None = None) -> tuple[POIR, POIRParams, dict]:
    """Load a checkpoint; if `config` / `layout` are given they must match the checkpoint's exactly."""
    path = Path(path)
    ck_config, ck_layout, raw = read(path)
    if config is not None and config != ck_config:
        diff = _first_difference(to_dict(config), to_dict(ck_config))
        raise CheckpointError(f"{path}: config field '{diff}' differs from the checkpoint's")
    if layout is not None:
        for k, v in layout.items():
            if ck_layout.get(k) != v:
                raise CheckpointError(
                    f"{path}: observation layout field '{k}' is {ck_layout.get(k)!r} in the checkpoint, expected {v!r}"
                )
    agent = POIR(ck_config, int(ck_layout["obs_size"]), int(ck_layout["act_size"]))
    params = POIRParams(
        bc=raw["bc"],
        wm=raw.get("wm"),
        reward_wm=raw.get("reward_wm"),
        obs_norm=Normalizer(raw["obs_norm"]["mean"], raw["obs_norm"]["std"]),
        act_norm=Normalizer(raw["act_norm"]["mean"], raw["act_norm"]["std"]),
        expert_states=raw["expert_states"],
    )
    params = jax.tree_util.tree_map(lambda x: jax.numpy.asarray(x, jax.numpy.float32), params)
    return agent, params, ck_layout


def _first_difference(a, b, prefix=""):
    for k in a:
        if isinstance(a[k], dict):
            d = _first_difference(a[k], b.get(k, {}), f"{prefix}{k}.")
            if d:
                return d
        elif a[k] != b.get(k):
            return f"{prefix}{k}"
    return None
