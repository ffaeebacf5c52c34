"""Choosing jax's backend from a config: a GPU asked for but not visible is an error, not a silent CPU run."""

from __future__ import annotations

DEVICES = ("any", "cpu", "gpu")
CUDA_HINT = "install jax's CUDA plugin with the current dependency set (make venv-gpu, or pip install -e '.[cuda13]')"


class DeviceError(RuntimeError):
    """The requested device is not available (the CLI prints one line and exits with status 2)."""


def select_device(device: str, where: str) -> str:
    """Apply `device` ("any", "cpu", "gpu") before any computation; returns the platform jax will use.

    `where` names the file and field (or the flag) the request came from, for the error message.
    """
    import jax

    if device not in DEVICES:
        raise DeviceError(f"{where}: expected one of {', '.join(DEVICES)}, got {device!r}")
    if device == "cpu":
        jax.config.update("jax_platforms", "cpu")
    elif device == "gpu":
        try:
            gpus = jax.devices("gpu")
        except RuntimeError:
            gpus = []
        if not gpus:
            raise DeviceError(f"{where}: a GPU was requested but jax {jax.__version__} sees none "
                              f"(default backend: {jax.default_backend()}); {CUDA_HINT}")  # fmt: skip
    return jax.default_backend()


def pin_precision() -> None:
    """Full float32 matrix products on accelerators, for the physics (MJX's solver) and the networks alike.

    On NVIDIA Hopper/Ampere jax runs float32 matmuls as TF32 (10-bit mantissa) by default; the MJX
    physics was validated against MuJoCo in full float32 (the L2 reward pins its own matmul already).
    On a CPU float32 products are full precision anyway and nothing is changed.
    """
    import jax

    if jax.default_backend() != "cpu":
        jax.config.update("jax_default_matmul_precision", "highest")


def precision_note() -> str:
    """What results record about matmul precision: empty on a CPU, else jax's setting (", matmul precision highest")."""
    import jax

    if jax.default_backend() == "cpu":
        return ""
    return f", matmul precision {jax.config.jax_default_matmul_precision or 'default (TF32)'}"
