"""Agent checkpoints: parameters, normalisation statistics, the config and the observation layout, in one file.

Format (``poir_mjx.checkpoint_codec``): {"format", "config" (JSON), "layout" (JSON), "params" (the
``POIRParams`` state dict, keyed by name)}. Loading rebuilds the agent from the stored config and
restores the parameters into its expected structure (shapes from ``jax.eval_shape``, nothing
computed), so every network layer, statistic and expert state is checked by name and shape.
Loaded parameters are float32 whatever precision they were saved in.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx import checkpoint_codec as codec
from poir_mjx.checkpoint_codec import CheckpointError
from poir_mjx.core import ensemble as ens
from poir_mjx.core.agent import POIR, POIRParams
from poir_mjx.core.config import ConfigError, POIRConfig, from_dict, to_dict
from poir_mjx.core.normalizer import Normalizer

FORMAT = "poir-mjx-checkpoint/2"  # 2: the expert data's disagreement levels


def save(path: str | Path, agent: POIR, params: POIRParams, layout: dict[str, Any]) -> Path:
    """Write a checkpoint atomically. `layout` describes the observations (keys, sizes, task, data provenance)."""
    return codec.write(path, FORMAT, {
        "config": json.dumps(to_dict(agent.config), sort_keys=True),
        "layout": json.dumps({**layout, "obs_size": agent.obs_size, "act_size": agent.act_size}, sort_keys=True),
        "params": codec.state_dict(params),
    })  # fmt: skip


def _read(path: Path) -> tuple[POIRConfig, dict, dict]:
    """(config, layout, the whole stored mapping) of a checkpoint file, with clear errors."""
    blob = codec.read(path, FORMAT)
    try:
        config = from_dict(codec.json_field(path, blob, "config"), POIRConfig, source=f"{path}: config")
    except ConfigError as e:
        raise CheckpointError(f"{path}: field 'config' is invalid ({e})") from e
    layout = codec.json_field(path, blob, "layout")
    for k in ("obs_size", "act_size"):
        if not isinstance(layout, dict) or not isinstance(layout.get(k), int):
            raise CheckpointError(f"{path}: field 'layout.{k}' is missing or not an integer")
    return config, layout, blob


def load(path: str | Path, config: POIRConfig | None = None,
         layout: dict | None = None) -> tuple[POIR, POIRParams, dict]:
    """Load a checkpoint; if `config` / `layout` are given they must match the checkpoint's exactly."""
    path = Path(path)
    ck_config, ck_layout, blob = _read(path)
    if config is not None and config != ck_config:
        diff = _first_difference(to_dict(config), to_dict(ck_config))
        raise CheckpointError(f"{path}: config field '{diff}' differs from the checkpoint's")
    if layout is not None:
        for k, v in layout.items():
            if ck_layout.get(k) != v:
                raise CheckpointError(
                    f"{path}: observation layout field '{k}' is {ck_layout.get(k)!r} in the checkpoint, expected {v!r}"
                )
    agent = POIR(ck_config, ck_layout["obs_size"], ck_layout["act_size"])
    params = codec.restore(path, params_template(agent, blob.get("params")), blob, "params", cast_floats=True,
                           finite=True)  # fmt: skip
    return agent, params, ck_layout


def params_template(agent: POIR, stored: Any = None) -> POIRParams:
    """The shapes and dtypes (``jax.ShapeDtypeStruct``) of `agent`'s parameters; what is data-dependent
    (world models present or not, the number of expert states) is read from the `stored` state dict."""
    stored = stored if isinstance(stored, dict) else {}
    k, do, da = agent.config.ensemble_size, agent.obs_size, agent.act_size
    key = jax.random.PRNGKey(0)

    def nets(module, n_in):
        return jax.eval_shape(lambda: ens.init_ensemble(module, key, k, n_in))

    def wm(name):
        return nets(agent.wm_module, do + da) if stored.get(name) is not None else None

    def vec(n):
        return jax.ShapeDtypeStruct((n,), jnp.float32)

    rows = (np.shape(stored.get("expert_states", 0)) or (0,))[0]
    return POIRParams(bc=nets(agent.bc_module, do), wm=wm("wm"), reward_wm=wm("reward_wm"),
                      obs_norm=Normalizer(vec(do), vec(do)), act_norm=Normalizer(vec(da), vec(da)),
                      expert_states=jax.ShapeDtypeStruct((rows, do), jnp.float32),
                      dril_level=jax.ShapeDtypeStruct((), jnp.float32),
                      morel_level=jax.ShapeDtypeStruct((), jnp.float32))  # fmt: skip


def _first_difference(a, b, prefix=""):
    for k in a:
        if isinstance(a[k], dict):
            d = _first_difference(a[k], b.get(k, {}), f"{prefix}{k}.")
            if d:
                return d
        elif a[k] != b.get(k):
            return f"{prefix}{k}"
    return None
