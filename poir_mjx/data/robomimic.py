"""robomimic's low-dim HDF5 layout, read and written exactly.

Layout::

    data/                     attrs: total (int), env_args (JSON: env_name, type, env_kwargs, ...)
    data/demo_<k>/            attrs: num_samples (int), model_file (MJCF, optional)
        actions [T, A]  rewards [T]  dones [T]  states [T, S]
        obs/<key> [T, d]      next_obs/<key> [T, d]
    mask/<filter>             array of demo names (bytes), e.g. mask/train, mask/valid

The reader loads only the requested observation keys (h5py slices on demand), validates
everything it touches and raises ``DatasetError`` naming the file, the demo and the field.
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
from pathlib import Path
from typing import Any, Sequence

import h5py
import numpy as np

from poir_mjx.atomic import atomic_path
from poir_mjx.envs.layout import ACTION_SIZE, OBS_KEYS
from poir_mjx.envs.tasks import ROBOSUITE_ENV

# robomimic's names for what poir_mjx.envs defines: its low-dim observation keys, and the
# env_args.env_name of each task (robosuite's class name).
LOW_DIM_KEYS = OBS_KEYS
ENV_NAMES = ROBOSUITE_ENV


def robosuite_obs(o: dict, keys=LOW_DIM_KEYS) -> dict[str, np.ndarray]:
    """robomimic's low-dim keys (float32; `keys` of them, in that order) from a robosuite observation dict ("object" is
    its "object-state")."""
    return {k: np.asarray(o["object-state" if k == "object" else k], np.float32) for k in keys}


class DatasetError(ValueError):
    """Invalid robomimic file; the message names the file, the demo and the field."""


@dataclasses.dataclass
class Transitions:
    """Expert transitions of a dataset, demos concatenated in file order."""

    obs: np.ndarray  # [N, d] the chosen keys concatenated
    actions: np.ndarray  # [N, A]
    next_obs: np.ndarray  # [N, d]
    demo_names: list[str]
    demo_starts: np.ndarray  # [D] index of each demo's first transition
    demo_lengths: np.ndarray  # [D]
    obs_keys: tuple[str, ...]
    obs_sizes: tuple[int, ...]
    env_args: dict[str, Any]
    provenance: dict[str, Any]  # data attrs other than total/env_args (e.g. our generator's description)
    path: str

    @property
    def num_transitions(self) -> int:
        return int(self.obs.shape[0])


def _demo_sort_key(name: str):
    m = re.fullmatch(r"demo_(\d+)", name)
    return (0, int(m.group(1))) if m else (1, name)


def _err(path, demo, field, msg) -> DatasetError:
    where = f"{path}" + (f": {demo}" if demo else "") + (f": {field}" if field else "")
    return DatasetError(f"{where}: {msg}")


def read_env_args(path: str | Path) -> dict:
    with h5py.File(path, "r") as f:
        if "data" not in f:
            raise _err(path, None, "data", "missing group")
        raw = f["data"].attrs.get("env_args")
        if raw is None:
            raise _err(path, None, "data.attrs['env_args']", "missing attribute")
        if not isinstance(raw, (str, bytes)):
            raise _err(path, None, "data.attrs['env_args']", f"expected a JSON string, got {type(raw).__name__}")
        try:
            env_args = json.loads(raw)
        except json.JSONDecodeError as e:
            raise _err(path, None, "data.attrs['env_args']", f"not valid JSON ({e})") from e
        if not isinstance(env_args, dict):
            raise _err(path, None, "data.attrs['env_args']", "expected a JSON object")
        return env_args


def read_transitions(
    path: str | Path,
    task: str | None = None,
    obs_keys: Sequence[str] = LOW_DIM_KEYS,
    filter_key: str | None = None,
    max_demos: int | None = None,
) -> Transitions:
    """Read (s, a, s') for `obs_keys` from a robomimic low-dim file, validating as it goes.

    `task` (lift, pick_place_can, nut_assembly_square) is checked against ``env_args.env_name``.
    `filter_key` selects the demos listed in ``mask/<filter_key>``.
    """
    path = str(path)
    try:
        return _read_transitions(path, task, obs_keys, filter_key, max_demos)
    except DatasetError:
        raise
    except (KeyError, OSError, TypeError, ValueError, RecursionError) as e:  # what the checks below did not foresee
        raise DatasetError(f"{path}: unreadable ({type(e).__name__}: {' '.join(str(e).split())[:200]})") from None


def _read_transitions(path: str, task, obs_keys, filter_key, max_demos) -> Transitions:
    with _open(path) as f:
        if "data" not in f or not isinstance(f["data"], h5py.Group):
            raise _err(path, None, "data", "missing group")
        data = f["data"]
        env_args = read_env_args(path)
        if task is not None:
            _check_env_name(path, env_args, task)
        names = _demo_names(path, f, filter_key, max_demos)
        obs_l, act_l, nxt_l, lengths, sizes = [], [], [], [], None
        for name in names:
            obs, act, nxt, demo_sizes = _read_demo(path, name, data[name], obs_keys)
            if sizes is None:
                sizes = demo_sizes
            elif demo_sizes != sizes:
                raise _err(path, name, "obs",
                           f"observation sizes {list(demo_sizes)} differ from earlier demos' {list(sizes)}")
            obs_l.append(obs), nxt_l.append(nxt), act_l.append(act)
            lengths.append(act.shape[0])
        provenance = {k: _attr(v) for k, v in data.attrs.items() if k not in ("total", "env_args")}
    lengths = np.array(lengths)
    return Transitions(
        obs=np.concatenate(obs_l).astype(np.float32),
        actions=np.concatenate(act_l).astype(np.float32),
        next_obs=np.concatenate(nxt_l).astype(np.float32),
        demo_names=list(names),
        demo_starts=np.concatenate([[0], np.cumsum(lengths)[:-1]]),
        demo_lengths=lengths,
        obs_keys=tuple(obs_keys),
        obs_sizes=sizes,
        env_args=env_args,
        provenance=provenance,
        path=path,
    )


def _open(path: str) -> h5py.File:
    """The HDF5 file at `path`, opened for reading, or a DatasetError saying why not."""
    if os.path.isdir(path):
        raise DatasetError(f"{path}: is a directory, expected a robomimic HDF5 file")
    if not os.path.isfile(path):
        raise DatasetError(f"{path}: no such file")
    try:
        return h5py.File(path, "r")
    except OSError as e:
        raise DatasetError(f"{path}: not an HDF5 file ({e})") from e


def _check_env_name(path: str, env_args: dict, task: str) -> None:
    want = ENV_NAMES.get(task)
    if want is None:
        raise DatasetError(f"task: unknown task {task!r}; expected one of {sorted(ENV_NAMES)}")
    if env_args.get("env_name") != want:
        raise _err(path, None, "data.attrs['env_args'].env_name",
                   f"is {env_args.get('env_name')!r}, expected {want!r} for task {task}")  # fmt: skip


def _demo_names(path: str, f: h5py.File, filter_key: str | None, max_demos: int | None) -> list[str]:
    """The demos to read, in robomimic's order (demo_0, demo_1, ..., demo_10): all, or those of the filter."""
    data = f["data"]
    names = sorted((k for k in data.keys() if isinstance(data[k], h5py.Group)), key=_demo_sort_key)
    if filter_key is not None:
        mpath = f"mask/{filter_key}"
        if mpath not in f:
            raise _err(path, None, mpath, "missing filter key")
        listed = [n.decode() if isinstance(n, bytes) else str(n) for n in f[mpath][()]]
        for n in listed:
            if n not in data:
                raise _err(path, n, mpath, f"filter lists demo {n!r} which is not in data/")
        names = sorted(listed, key=_demo_sort_key)
    if max_demos is not None:
        names = names[:max_demos]
    if not names:
        raise _err(path, None, "data", "no demos")
    return names


def _read_demo(path: str, name: str, demo: h5py.Group, obs_keys: Sequence[str]):
    """(obs [T, d], actions [T, A], next_obs [T, d], each key's size) of one demo, every field validated."""
    act = _read(path, name, demo, "actions", ndim=2)
    t = act.shape[0]
    if t == 0:
        raise _err(path, name, "actions", "empty demo (0 samples)")
    if act.shape[1] != ACTION_SIZE:
        raise _err(path, name, "actions", f"action size {act.shape[1]}, expected {ACTION_SIZE}")
    ns = demo.attrs.get("num_samples")
    if ns is not None:
        if np.ndim(ns) != 0 or not isinstance(ns.item() if hasattr(ns, "item") else ns, int) or isinstance(ns, bool):
            raise _err(path, name, "attrs['num_samples']", f"must be an integer, got {_attr(ns)!r}")
        if int(ns) != t:
            raise _err(path, name, "attrs['num_samples']", f"is {int(ns)} but actions has {t} rows")
    for group in ("obs", "next_obs"):
        if group not in demo:
            raise _err(path, name, group, "missing group")
        try:
            node = demo[group]
        except (KeyError, OSError) as e:  # a dangling link
            raise _err(path, name, group, f"cannot be read ({' '.join(str(e).split())})") from None
        if not isinstance(node, h5py.Group):
            raise _err(path, name, group, "is a dataset, expected a group")
    parts, nparts = [], []
    for key in obs_keys:
        o = _read(path, name, demo["obs"], key, ndim=2, field=f"obs/{key}")
        n = _read(path, name, demo["next_obs"], key, ndim=2, field=f"next_obs/{key}")
        for fld, arr in ((f"obs/{key}", o), (f"next_obs/{key}", n)):
            if arr.shape[0] != t:
                raise _err(path, name, fld, f"length {arr.shape[0]} differs from actions length {t}")
        if o.shape[1] != n.shape[1]:
            raise _err(path, name, f"next_obs/{key}", f"size {n.shape[1]} differs from obs/{key} size {o.shape[1]}")
        parts.append(o), nparts.append(n)
    return np.concatenate(parts, 1), act, np.concatenate(nparts, 1), tuple(p.shape[1] for p in parts)


def _attr(v):
    if isinstance(v, bytes):
        v = v.decode()
    if isinstance(v, str):
        try:
            return json.loads(v)
        except json.JSONDecodeError:
            return v
    if isinstance(v, np.ndarray):
        return v.tolist() if v.size != 1 else v.item()
    return v.item() if hasattr(v, "item") else v


def _read(path, demo_name, group, key, ndim, field=None) -> np.ndarray:
    """A real-valued dataset as float32 (what training uses), finite after the conversion (1e39 is not)."""
    field = field or key
    if key not in group:
        raise _err(path, demo_name, field, "missing dataset")
    try:
        node = group[key]
        arr = node[()] if isinstance(node, h5py.Dataset) else None
    except (KeyError, OSError, ValueError, TypeError) as e:  # a dangling (external) link, an unreadable dataset
        raise _err(path, demo_name, field, f"cannot be read ({' '.join(str(e).split())})") from None
    if arr is None:
        raise _err(path, demo_name, field, "is a group, expected a dataset")
    if np.ndim(arr) != ndim:
        raise _err(path, demo_name, field, f"expected {ndim} dimensions, got shape {np.shape(arr)}")
    if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
        raise _err(path, demo_name, field, f"not real numbers (dtype {arr.dtype})")
    with np.errstate(over="ignore", invalid="ignore"):
        arr = arr.astype(np.float32)
    if not np.all(np.isfinite(arr)):
        bad = int(np.argwhere(~np.isfinite(arr))[0][0])
        raise _err(path, demo_name, field, f"NaN or inf at row {bad} (in float32, as training reads it)")
    return arr


@dataclasses.dataclass
class Demo:
    obs: dict[str, np.ndarray]  # key -> [T, d]
    next_obs: dict[str, np.ndarray]
    actions: np.ndarray  # [T, A]
    rewards: np.ndarray  # [T]
    dones: np.ndarray  # [T]
    states: np.ndarray  # [T, S] simulator states to replay the demo
    model_file: str | None = None


def write_robomimic(
    path: str | Path,
    demos: Sequence[Demo],
    env_args: dict,
    masks: dict[str, Sequence[str]] | None = None,
    extra_attrs: dict[str, Any] | None = None,
) -> Path:
    """Write demos in robomimic's layout, atomically (temporary file in the same folder, then rename)."""
    path = Path(path)
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as f:
            data = f.create_group("data")
            total = 0
            for k, d in enumerate(demos):
                g = data.create_group(f"demo_{k}")
                t = int(d.actions.shape[0])
                g.attrs["num_samples"] = t
                if d.model_file is not None:
                    g.attrs["model_file"] = d.model_file
                g.create_dataset("actions", data=np.asarray(d.actions, np.float64))
                g.create_dataset("rewards", data=np.asarray(d.rewards, np.float64))
                g.create_dataset("dones", data=np.asarray(d.dones, np.int64))
                g.create_dataset("states", data=np.asarray(d.states, np.float64))
                for grp, obs in (("obs", d.obs), ("next_obs", d.next_obs)):
                    og = g.create_group(grp)
                    for key, v in obs.items():
                        og.create_dataset(key, data=np.asarray(v, np.float64))
                total += t
            data.attrs["total"] = total
            data.attrs["env_args"] = json.dumps(env_args)
            for k, v in (extra_attrs or {}).items():
                data.attrs[k] = v if isinstance(v, (int, float, str)) else json.dumps(v)
            if masks:
                mg = f.create_group("mask")
                for name, demos_listed in masks.items():
                    mg.create_dataset(name, data=np.array([s.encode() for s in demos_listed], dtype="S"))
    return path
