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


def pytest_runtest_teardown(item, nextitem):
    """Between test folders, drop the compiled programs the last folder kept alive: the project's lru-cached
    builders (compiled evaluators, environments, recorders) and jax's own caches. A folder's tests share their
    programs; the next folder's rarely do, and JAX's persistent compilation cache makes a recompile a disk read.
    Without this the CPU suite's process grew to 14 GB resident (issue 43)."""
    if nextitem is not None and Path(nextitem.path).parent == Path(item.path).parent:
        return
    import functools
    import gc

    import jax

    for name, module in list(sys.modules.items()):
        if not name.startswith("poir_mjx"):
            continue
        for value in list(vars(module).values()):
            if isinstance(value, functools._lru_cache_wrapper):
                value.cache_clear()
    jax.clear_caches()
    gc.collect()
    if sys.platform.startswith("linux"):  # hand the freed pages back to the OS (glibc keeps them otherwise)
        import ctypes

        try:
            ctypes.CDLL("libc.so.6").malloc_trim(0)
        except (OSError, AttributeError):
            pass
