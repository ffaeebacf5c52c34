"""Optional dependencies: robosuite is needed only to export models, as the reference simulator and for robosuite demos.

Everything else (environments, training, planning, evaluation, sweeps with MJX demos) runs without it.
"""

from __future__ import annotations

import importlib


class MissingDependencyError(RuntimeError):
    """A feature needs a package that is not installed (the CLI prints one line and exits with status 2)."""


ROBOSUITE_HINT = (
    "install the CPU dependency set, which includes it (`make venv`, Python 3.11: pip install -e '.[robosuite]'), "
    "or use MJX instead (e.g. demo_simulator \"mjx\" in a sweep config, `make demos DEMO_SIM=mjx`)"
)


def require_robosuite(feature: str):
    """Import and return robosuite, or raise MissingDependencyError naming `feature` and how to install it."""
    try:
        return importlib.import_module("robosuite")
    except ImportError as e:
        raise MissingDependencyError(f"{feature} needs robosuite, which is not installed ({e}); {ROBOSUITE_HINT}") from None


def has_robosuite() -> bool:
    try:
        importlib.import_module("robosuite")
    except ImportError:
        return False
    return True


def warp_installed() -> bool:
    """Whether MJX can run MuJoCo Warp here: mujoco-mjx 3.17 or newer, which ships it, and warp-lang importable."""
    try:
        from mujoco.mjx._src import io
    except ImportError:
        return False
    return bool(getattr(getattr(io, "mjxw", None), "WARP_INSTALLED", False))
