"""The one place where the two supported jax versions (0.7.0 and 0.11.2, README "Dependencies") differ."""

from __future__ import annotations

import contextlib

import jax


def x64_enabled() -> bool:
    """Whether jax currently creates float64 arrays by default (global flag or an enable_x64 scope)."""
    return jax.numpy.zeros(()).dtype == jax.numpy.float64


@contextlib.contextmanager
def enable_x64(enabled: bool = True):
    """Scope in which jax's default float is float64 (jax >= 0.8: jax.enable_x64; before: jax.experimental)."""
    if hasattr(jax, "enable_x64"):
        ctx = jax.enable_x64(enabled)
    else:
        from jax.experimental import disable_x64
        from jax.experimental import enable_x64 as _enable

        ctx = _enable() if enabled else disable_x64()
    with ctx:
        yield
