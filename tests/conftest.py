import os
import sys
from pathlib import Path

import pytest

# JAX's persistent compilation cache in the user's cache folder (the Makefile's, shared by every clone on the
# machine): MJX programs take minutes to compile on CPU.
_CACHE_HOME = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", str(_CACHE_HOME / "poir-mjx" / "jax-cpu"))
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "1")
# Headless OpenGL for the video tests (tests/video): MuJoCo reads it when first imported.
if sys.platform.startswith("linux"):
    os.environ.setdefault("MUJOCO_GL", "egl")
# The suite runs the float32 path that users run (`make sweep`); tests that need float64 physics
# (NutAssemblySquare's fidelity test) open a `poir_mjx.compat.enable_x64()` scope themselves.


def pytest_collection_modifyitems(config, items):
    """Skip the tests that need robosuite (export, reference simulator, robosuite demos) where it is missing."""
    from poir_mjx.optional import has_robosuite

    if has_robosuite():
        return
    skip = pytest.mark.skip(reason="needs robosuite, which the current dependency set (Python 3.12+, numpy 2) has not")
    for item in items:
        if "needs_robosuite" in item.keywords:
            item.add_marker(skip)
