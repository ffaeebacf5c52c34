"""``make demos``: scripted-expert demonstrations in robomimic's HDF5 layout (the commands: ``cli/demos.py``;
the expert's success rate: ``eval/expert_success.py``).

    python -m poir_mjx.cli demos generate --tasks lift --num 200      # -> data/demos/<task>.hdf5
    python -m poir_mjx.cli demos generate --simulator mjx --batch 256 # -> data/demos/<task>-mjx.hdf5
    python -m poir_mjx.cli demos generate --tasks lift --demo-style human_like  # -> data/demos/<task>-human.hdf5
    python -m poir_mjx.cli demos success --simulator robosuite --episodes 100

Demonstrations are recorded at sigma_init 0.02 with no action noise, keeping only successful
episodes, either in robosuite (MuJoCo C, as robomimic's were; needs robosuite) or in MJX
(vectorised, ``mjx_demos.py``; no robosuite). A file that already holds the requested
demonstrations with the same generator settings is left alone (``make demos`` skips done work).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from poir_mjx.data import expert as ex
from poir_mjx.data import mjx_demos
from poir_mjx.data.robomimic import ENV_NAMES, write_robomimic
from poir_mjx.data.expert_episodes import robosuite_episode
from poir_mjx.envs.tasks import DEFAULT_NUM_DEMOS, make_robosuite, robosuite_kwargs
from poir_mjx.optional import require_robosuite

SIMULATORS = ("robosuite", "mjx")


def generator_info(task: str, num: int, seed: int, sigma_init: float, style: str = "scripted") -> dict:
    import mujoco

    robosuite = require_robosuite("recording demos in robosuite")
    simulator = f"robosuite {robosuite.__version__} (MuJoCo {mujoco.__version__})"
    return ex.generator_record(task, num, seed, sigma_init, simulator, style)


def env_args(task: str, sigma_init: float) -> dict:
    robosuite = require_robosuite("recording demos in robosuite")

    kw = {k: v for k, v in robosuite_kwargs(None).items() if k not in ("seed",)}
    kw["robots"] = ["Panda"]
    kw["initialization_noise"] = {"magnitude": sigma_init, "type": "gaussian"}
    return {"env_name": ENV_NAMES[task], "type": 1, "env_version": robosuite.__version__, "env_kwargs": kw}


def demo_path(task: str, out: Path, simulator: str = "robosuite", num: int = DEFAULT_NUM_DEMOS,
              style: str = "scripted") -> Path:  # fmt: skip
    """data/demos/<task>[-<simulator>][-human][-n<num>].hdf5: DEFAULT_NUM_DEMOS scripted robosuite demos keep the
    plain name, and a different count, simulator or style never overwrites another's file."""
    name = task + ("" if simulator == "robosuite" else f"-{simulator}")
    name += "" if style == "scripted" else "-human"
    name += "" if num == DEFAULT_NUM_DEMOS else f"-n{num}"
    return Path(out) / f"{name}.hdf5"


def existing_matches(path: Path, info: dict) -> bool:
    if not path.exists():
        return False
    try:
        import h5py

        with h5py.File(path, "r") as f:
            return json.loads(f["data"].attrs.get("poir_mjx_generator", "{}")) == info
    except Exception:
        return False


def generate(task: str, num: int, seed: int, sigma_init: float, out: Path, progress: bool = True,
             simulator: str = "robosuite", batch: int = 16, style: str = "scripted") -> Path:  # fmt: skip
    """Make (or reuse) `num` successful expert demos of `task` recorded in `simulator` by the expert in `style`
    (expert.STYLES); returns the file."""
    from tqdm import tqdm

    if simulator not in SIMULATORS:
        raise ValueError(f"simulator: expected one of {', '.join(SIMULATORS)}, got {simulator!r}")
    if style not in ex.STYLES:
        raise ValueError(f"demo style: expected one of {', '.join(ex.STYLES)}, got {style!r}")
    path = demo_path(task, out, simulator, num, style)
    info_fn = mjx_demos.generator_info if simulator == "mjx" else generator_info
    info = info_fn(task, num, seed, sigma_init, style)
    if existing_matches(path, info):
        print(f"{path}: already holds {num} demos from the same generator settings; skipped")
        return path
    if simulator == "mjx":
        st = mjx_demos.generate_mjx(task, num, seed, sigma_init, path, batch=batch, progress=progress,
                                    style=style)  # fmt: skip
        print(f"wrote {path}: {num} demos (MJX), success {num}/{st['episodes_tried']} tried, length mean "
              f"{st['length_mean']:.0f} min {st['length_min']} max {st['length_max']}, {st['seconds']:.0f} s")  # fmt: skip
        return path
    env = make_robosuite(task, seed=seed, initialization_noise={"magnitude": sigma_init, "type": "gaussian"})
    model_xml = env.sim.model.get_xml()
    demos, tried, lengths, t0 = [], 0, [], time.perf_counter()
    bar = tqdm(total=num, desc=f"demos {task}" + ("" if style == "scripted" else f" ({style})"), unit="demo",
               disable=not progress)  # fmt: skip
    while len(demos) < num:
        demo, ok, steps, _ = robosuite_episode(task, seed * 100003 + tried, sigma_init, env=env, style=style)
        tried += 1
        if ok:
            demo.model_file = model_xml
            demos.append(demo)
            lengths.append(steps)
            bar.update(1)
        bar.set_postfix(success=f"{len(demos)}/{tried}")
        if tried > 3 * num + 20:
            raise RuntimeError(f"{task}: the scripted expert succeeded in only {len(demos)} of {tried} episodes")
    bar.close()
    stats = {
        **info,
        "episodes_tried": tried,
        "success_rate": len(demos) / tried,
        "length_mean": float(np.mean(lengths)),
        "length_min": int(np.min(lengths)),
        "length_max": int(np.max(lengths)),
        "seconds": time.perf_counter() - t0,
    }
    n_valid = max(1, num // 10)
    names = [f"demo_{k}" for k in range(num)]
    write_robomimic(
        path,
        demos,
        env_args(task, sigma_init),
        masks={"train": names[n_valid:], "valid": names[:n_valid]},
        extra_attrs={"poir_mjx_generator": json.dumps(info, sort_keys=True), "poir_mjx_stats": json.dumps(stats)},
    )
    print(f"wrote {path}: {num} demos, success {len(demos)}/{tried}, length mean {stats['length_mean']:.0f} "
          f"min {stats['length_min']} max {stats['length_max']}, {stats['seconds']:.0f} s")  # fmt: skip
    return path
