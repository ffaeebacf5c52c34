"""``python -m poir_mjx.video --run results/cpu-small --method EBC --versus POIR-DRIL --sigma-init 0.4`` (make video).

The flags are ``VideoConfig``'s fields (tyro builds them; without tyro, a plain argparse reading of the
same fields). Bad input, a missing EGL/OSMesa or a missing checkpoint file: one line, exit status 2.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import typing
from pathlib import Path

from poir_mjx.video import VideoConfig, render_video  # sets MUJOCO_GL before mujoco is imported


def parse(argv: list[str] | None) -> VideoConfig:
    try:
        import tyro
    except ImportError:
        return _parse_without_tyro(argv)
    return tyro.cli(VideoConfig, args=argv)


def _parse_without_tyro(argv: list[str] | None) -> VideoConfig:
    p = argparse.ArgumentParser(prog="python -m poir_mjx.video", description=VideoConfig.__doc__)
    hints = typing.get_type_hints(VideoConfig)
    for f in dataclasses.fields(VideoConfig):
        t = hints[f.name]
        kind = next((a for a in typing.get_args(t) if a is not type(None)), t)  # X | None -> X
        flag = "--" + f.name.replace("_", "-")
        if typing.get_origin(t) is tuple:
            p.add_argument(flag, type=typing.get_args(t)[0], nargs="+", default=f.default)
        elif f.default is dataclasses.MISSING:
            p.add_argument(flag, type=kind, required=True)
        else:
            p.add_argument(flag, type=kind, default=f.default)
    ns = vars(p.parse_args(argv))
    return VideoConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in ns.items()})


def main(argv: list[str] | None = None) -> int:
    from poir_mjx.core.checkpoint import CheckpointError
    from poir_mjx.core.config import ConfigError
    from poir_mjx.data.robomimic import DatasetError
    from poir_mjx.eval.methods import UnknownMethodError
    from poir_mjx.optional import MissingDependencyError

    from poir_mjx.video.render import check_gl

    cfg = parse(argv)
    try:
        check_gl()  # mujoco's first import: a missing OSMesa fails there, before minutes of compilation
    except MissingDependencyError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    from poir_mjx.envs.env import ModelFileError

    try:
        path = render_video(cfg)
    except (ConfigError, CheckpointError, DatasetError, UnknownMethodError, MissingDependencyError,
            ModelFileError) as e:  # fmt: skip
        print(f"error: {e}", file=sys.stderr)
        return 2
    size = Path(path).stat().st_size
    print(f"wrote {path} ({size / 1e6:.2f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
