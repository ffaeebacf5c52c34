"""One stage's result file, ``<out>/<stage>.json``: what machine and software measured it, its rows, written
again after every row (an interrupted stage keeps what it measured), and whether the stage completed."""

from __future__ import annotations

import json
import platform
from pathlib import Path

from poir_mjx.atomic import atomic_write_text


def machine() -> dict:
    """The device, its driver, the software and the precision every result names."""
    import jax

    from poir_mjx.versions import command_line
    from poir_mjx.versions import stack

    d = jax.devices()[0]
    try:
        driver = d.client.platform_version
    except AttributeError:
        driver = None
    return {"device": f"{d.platform}:{getattr(d, 'device_kind', '')}", "device_count": jax.device_count(),
            "driver": driver, "host": platform.processor() or platform.machine(), "versions": stack(),
            "matmul_precision": jax.config.jax_default_matmul_precision or "default",
            "x64": bool(jax.config.jax_enable_x64), "command": command_line()}  # fmt: skip


# What jax reports of each compilation (jax.monitoring), summed for the stage being recorded: how many programs a
# stage compiles and where its compile time goes, so the stages' deadlines can be budgeted by compilations.
_EVENTS = {"/jax/core/compile/backend_compile_duration": "backend_compile", "/jax/core/compile/jaxpr_trace_duration":
           "trace", "/jax/core/compile/jaxpr_to_mlir_module_duration": "lowering"}  # fmt: skip
_current: list = []


def _on_event(event: str, seconds: float, **kwargs) -> None:
    name = _EVENTS.get(event)
    if name and _current:
        c = _current[-1].data["compilations"]
        c[f"{name}_s"] += seconds
        if name == "backend_compile":
            c["programs"] += 1


class Record:
    def __init__(self, out: Path, stage: str, sizes: dict, dry_run: bool):
        import jax

        self.path = Path(out) / f"{stage}.json"
        self.data = {"stage": stage, "dry_run": dry_run, "complete": False, "machine": machine(), "sizes": sizes,
                     "compilations": {"programs": 0, "backend_compile_s": 0.0, "trace_s": 0.0, "lowering_s": 0.0},
                     "rows": []}  # fmt: skip
        if not _current:
            jax.monitoring.register_event_duration_secs_listener(_on_event)
        _current[:] = [self]
        self._write()

    def add(self, row: dict) -> None:
        self.data["rows"].append(row)
        print(f"{self.data['stage']}: {json.dumps(row)}", flush=True)
        self._write()

    def done(self) -> None:
        self.data["complete"] = True
        self._write()

    def _write(self) -> None:
        atomic_write_text(self.path, json.dumps(self.data, indent=2, default=str) + "\n")


def read(out: Path, stage: str) -> dict | None:
    """A stage's file if it is readable JSON (None otherwise: the stage runs again)."""
    try:
        data = json.loads((Path(out) / f"{stage}.json").read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None
