"""The software stack a result was produced with (for tables, benchmarks and demo provenance)."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version


def package_version(name: str) -> str | None:
    try:
        return version(name)
    except PackageNotFoundError:
        return None


def mjx_version() -> str:
    return package_version("mujoco-mjx") or "?"


def stack() -> dict[str, str | None]:
    """Versions of Python, jax, jaxlib, mujoco, mujoco-mjx, numpy, flax and robosuite (None: not installed)."""
    import platform

    out = {"python": platform.python_version()}
    for name in ("jax", "jaxlib", "mujoco", "mujoco-mjx", "numpy", "flax", "robosuite"):
        out[name] = package_version(name)
    return out


def stack_line() -> str:
    s = stack()
    rs = s["robosuite"] or "not installed"
    return (f"Python {s['python']}, jax {s['jax']}, mujoco {s['mujoco']}, mujoco-mjx {s['mujoco-mjx']}, "
            f"numpy {s['numpy']}, robosuite {rs}")  # fmt: skip


def simulator_line(simulator: str) -> str:
    """Which simulator produced a result, with its version: "MJX (mujoco-mjx 3.3.7, float32)" or robosuite's."""
    if simulator == "robosuite":
        return f"robosuite {package_version('robosuite') or '?'} (MuJoCo {package_version('mujoco') or '?'})"
    import jax

    return f"MJX (mujoco-mjx {mjx_version()}, {'float64' if jax.config.jax_enable_x64 else 'float32'})"
