"""A robomimic file cut down to what training reads: each demo's actions and low-dim observations (float32) and
its sample count, the file's attributes (environment, generator, statistics) kept; no simulator states, rewards or
per-demo model XML. Training on it gives the same transitions, so the
same content digest, checkpoints and cell hashes as the original: 200 Lift demos shrink from 15.9 MB to
2.5 MB, small enough to carry to an offline GPU machine (``make gpu-carry``)."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from poir_mjx.atomic import atomic_path
from poir_mjx.data.robomimic import LOW_DIM_KEYS, DatasetError


def compact(src: str | Path, dst: str | Path) -> Path:
    """Write the compact copy of robomimic file `src` to `dst` (atomically); returns `dst`."""
    src, dst = Path(src), Path(dst)
    if src.resolve() == dst.resolve():
        raise DatasetError(f"{dst}: the compact copy cannot replace its source {src}")
    try:
        fin = h5py.File(src, "r")
    except OSError as e:
        raise DatasetError(f"{src}: not a readable HDF5 file ({e})") from None
    with fin, atomic_path(dst) as tmp, h5py.File(tmp, "w", libver="latest") as fout:
        if "data" not in fin:
            raise DatasetError(f"{src}: field 'data' is missing (not a robomimic file)")
        data_in, data_out = fin["data"], fout.create_group("data")
        for k, v in data_in.attrs.items():
            data_out.attrs[k] = v
        for name, demo in data_in.items():
            g = data_out.create_group(name)
            g.attrs["num_samples"] = demo.attrs["num_samples"]  # not the model XML robosuite keeps per demo
            g.create_dataset("actions", data=np.asarray(demo["actions"], np.float32))
            for grp in ("obs", "next_obs"):
                og = g.create_group(grp)
                for key in LOW_DIM_KEYS:
                    if key not in demo[grp]:
                        raise DatasetError(f"{src}: field 'data/{name}/{grp}/{key}' is missing")
                    og.create_dataset(key, data=np.asarray(demo[grp][key], np.float32))
    return dst
