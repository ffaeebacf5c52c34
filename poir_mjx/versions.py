"""The software stack a result was produced with (for tables, benchmarks and demo provenance)."""

from __future__ import annotations

import contextvars
from importlib.metadata import PackageNotFoundError, version

_ARGV: contextvars.ContextVar[list[str]] = contextvars.ContextVar("poir_mjx_cli_argv", default=[])


def set_command_line(argv: list[str]) -> None:
    """Called by the command line (``poir_mjx.cli.main``) with its arguments."""
    _ARGV.set(list(argv))


def command_line() -> str:
    """The command being run, as results record it."""
    return " ".join(["python -m poir_mjx.cli", *_ARGV.get()])


def package_version(name: str) -> str | None:
    try:
        return version(name)
    except PackageNotFoundError:
        return None


def mjx_version() -> str:
    return package_version("mujoco-mjx") or "?"


def mujoco_version() -> str | None:
    """MuJoCo's own version (``mujoco.__version__``): MuJoCo 4 ships the module in split distributions
    (mujoco-core, ...) with no distribution named ``mujoco``, so its metadata cannot say."""
    try:
        import mujoco
    except ImportError:
        return None
    return getattr(mujoco, "__version__", None) or package_version("mujoco") or package_version("mujoco-core")


def stack() -> dict[str, str | None]:
    """Versions of Python, jax, jaxlib, mujoco, mujoco-mjx, numpy, flax and robosuite (None: not installed)."""
    import platform

    out = {"python": platform.python_version()}
    for name in ("jax", "jaxlib", "mujoco", "mujoco-mjx", "numpy", "flax", "robosuite"):
        out[name] = mujoco_version() if name == "mujoco" else package_version(name)
    return out


def stack_line() -> str:
    s = stack()
    rs = s["robosuite"] or "not installed"
    return (f"Python {s['python']}, jax {s['jax']}, mujoco {s['mujoco']}, mujoco-mjx {s['mujoco-mjx']}, "
            f"numpy {s['numpy']}, robosuite {rs}")  # fmt: skip


def simulator_line(simulator: str) -> str:
    """Which simulator produced a result, with its version: "MJX (mujoco-mjx 3.3.7, float32)" or robosuite's."""
    if simulator == "robosuite":
        return f"robosuite {package_version('robosuite') or '?'} (MuJoCo {mujoco_version() or '?'})"
    import jax

    from poir_mjx.devices import precision_note

    return f"MJX (mujoco-mjx {mjx_version()}, {'float64' if jax.config.jax_enable_x64 else 'float32'}{precision_note()})"


def machine_line() -> str:
    """The processor (its model name where Linux says it) and core count: results may differ between machines."""
    import os
    import platform

    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            model = next((ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")), model)
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores"
