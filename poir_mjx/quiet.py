"""Silence the import-time messages that are known and harmless here, and only those.

- robosuite warns, on every import (every worker process), that it has no private macro file and no
  ``robosuite_models`` or mink (robots and an IK controller this project never uses);
- MJX prints "Failed to import warp" / "mujoco_warp" when the optional Warp backend is absent.

A logging filter drops those robosuite records by their text; MJX's warp module is imported with its
standard output captured and the two lines about the missing ``warp`` package dropped. Every other
warning and line passes as before. Installed once, by ``import poir_mjx``.
"""

from __future__ import annotations

import contextlib
import importlib.abc
import io
import logging
import sys

ROBOSUITE_KNOWN = ("No private macro file found", "It is recommended to use a private macro file",
                   "To setup, run:", "Could not import robosuite_models", "Could not load the mink-based whole-body IK")  # fmt: skip
WARP_KNOWN = ("Failed to import warp: No module named 'warp'", "Failed to import mujoco_warp: No module named 'warp'")


class _KnownRobosuiteWarnings(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        return not any(k in record.getMessage() for k in ROBOSUITE_KNOWN)


class _QuietWarpImport(importlib.abc.MetaPathFinder):
    """Finds ``mujoco.mjx.warp`` with the other finders, then runs its module code with the known lines dropped."""

    NAME = "mujoco.mjx.warp"

    def find_spec(self, fullname, path, target=None):
        if fullname != self.NAME:
            return None
        for finder in sys.meta_path:
            if finder is self or not hasattr(finder, "find_spec"):
                continue
            spec = finder.find_spec(fullname, path, target)
            if spec is not None and spec.loader is not None and hasattr(spec.loader, "exec_module"):
                run = spec.loader.exec_module

                def exec_module(module, run=run):
                    buf = io.StringIO()
                    try:
                        with contextlib.redirect_stdout(buf):
                            run(module)
                    finally:
                        for line in buf.getvalue().splitlines(keepends=True):
                            if not line.startswith(WARP_KNOWN):
                                sys.stdout.write(line)

                spec.loader.exec_module = exec_module
                return spec
        return None


def install() -> None:
    robosuite_log = logging.getLogger("robosuite_logs")
    if not any(isinstance(f, _KnownRobosuiteWarnings) for f in robosuite_log.filters):
        robosuite_log.addFilter(_KnownRobosuiteWarnings())
    if not any(isinstance(f, _QuietWarpImport) for f in sys.meta_path):
        sys.meta_path.insert(0, _QuietWarpImport())
