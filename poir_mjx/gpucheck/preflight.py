"""``python -m poir_mjx.gpucheck.preflight``: are the packages gpu-check needs importable? One line and exit
status 2 naming the missing ones (run before the command line, which itself needs tyro)."""

from __future__ import annotations

import importlib
import sys

NEEDED = ("jax", "jaxlib", "flax", "optax", "numpy", "scipy", "h5py", "matplotlib", "tqdm", "absl", "etils",
          "mujoco", "mujoco.mjx", "trimesh", "tyro", "typeguard", "docstring_parser")  # fmt: skip


def missing() -> list[str]:
    gone = []
    for name in NEEDED:
        try:
            importlib.import_module(name)
        except Exception:  # noqa: BLE001 - any failure to import counts as missing
            gone.append(name)
    return gone


def main() -> int:
    gone = missing()
    if gone:
        print(f"error: gpu-check: missing Python packages {', '.join(gone)}; carry their wheels in .whl/ "
              "(make gpu-carry on a machine with network; docs/gpu.md)", file=sys.stderr)  # fmt: skip
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
