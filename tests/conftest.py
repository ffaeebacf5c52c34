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


# The test files that take longest with an empty compilation cache (their MJX programs compile for minutes each), in
# that order: they run first, so under pytest-xdist (`make test-cpu`: --dist loadfile --no-loadscope-reorder, a file
# stays in one process) the two workers start on the long files and the short ones fill the gaps at the end. Cold
# times measured on the 2-core AMD EPYC (2026-12-07, `make test-cpu CACHE_HOME=<empty>`): PickPlaceCan's and Square's
# replays and rollouts about 15-17 min each, the tiny sweeps 16, Lift's 9, the robosuite-versus-MJX check and the
# MJX demos about 9-10, the solver patch 7 (before the envs files were split per task).
LONGEST_FIRST = (
    "tests/envs/test_nut_assembly_square.py",
    "tests/envs/test_pick_place_can.py",
    "tests/sweep/test_sweep.py",
    "tests/envs/test_lift.py",
    "tests/eval/test_robosuite_eval.py",
    "tests/data/test_mjx_demos.py",
    "tests/envs/test_solver_patch.py",
    "tests/sweep/test_object_observation.py",
    "tests/video/test_video.py",
    "tests/envs/test_object_observation.py",
    "tests/eval/test_oracle.py",
)


def _suite_path(item) -> str:
    return Path(item.path).relative_to(Path(__file__).parent.parent).as_posix()


def pytest_collection_modifyitems(config, items):
    """Run LONGEST_FIRST's files first (the rest in pytest's order); skip the tests that need robosuite (export,
    reference simulator, robosuite demos) or MuJoCo Warp where it is missing."""
    from poir_mjx.optional import has_robosuite, warp_installed

    rank = {path: i for i, path in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(_suite_path(item), len(rank)))  # stable: a file's tests keep their order

    missing = {}
    if not has_robosuite():
        missing["needs_robosuite"] = "needs robosuite, which the current dependency set (Python 3.12+, numpy 2) has not"
    if not warp_installed():
        missing["needs_warp"] = "needs MuJoCo Warp: mujoco-mjx 3.17 with warp-lang 1.18.0 (make test-warp)"
    for item in items:
        for marker, reason in missing.items():
            if marker in item.keywords:
                item.add_marker(pytest.mark.skip(reason=reason))


# Seconds of XLA compilation per test file: [compiled here, saved by the persistent cache's hits (what compiling
# would have cost), programs compiled, cache hits]. What CI's time is made of (docs/make-targets.md, `make test`).
_COMPILE: dict[str, list] = {}
_CURRENT_FILE = ["(collection)"]
_BACKEND_COMPILE = "/jax/core/compile/backend_compile_duration"
_CACHE_SAVED = "/jax/compilation_cache/compile_time_saved_sec"


def _record_compile(event: str, duration: float, **_) -> None:
    """jax.monitoring listener: charge a compilation (or a cache hit's saved time) to the running test's file."""
    if event not in (_BACKEND_COMPILE, _CACHE_SAVED):
        return
    row = _COMPILE.setdefault(_CURRENT_FILE[0], [0.0, 0.0, 0, 0])
    if event == _BACKEND_COMPILE:
        row[0] += duration
        row[2] += 1
    else:  # a hit: its backend event (the read's time) is counted above too
        row[1] += duration
        row[3] += 1


def pytest_configure(config):
    from jax import monitoring

    monitoring.register_event_duration_secs_listener(_record_compile)


def pytest_runtest_setup(item):
    _CURRENT_FILE[0] = _suite_path(item)


def pytest_runtest_teardown(item, nextitem):
    """Between test folders, drop the compiled programs the last folder kept alive: the project's memoised
    builders (poir_mjx.cached: compiled evaluators, environments, recorders) and jax's own caches. A folder's tests
    share their programs; the next folder's rarely do, and JAX's persistent compilation cache makes a recompile a
    disk read. Without this the CPU suite's process grew to 14 GB resident (issue 43)."""
    if nextitem is not None and Path(nextitem.path).parent == Path(item.path).parent:
        return
    before = _resident_mb()
    _drop_compiled_programs()
    _FOLDER_MEMORY.append((str(Path(item.path).parent.relative_to(Path(__file__).parent.parent)), before,
                           _resident_mb(), _peak_mb()))  # fmt: skip


# (folder, resident MB at its end, resident MB after the drop, the process's peak MB so far), one per test folder run
_FOLDER_MEMORY: list[tuple[str, float, float, float]] = []


def _resident_mb() -> float:
    """This process's resident memory now (Linux /proc; NaN elsewhere)."""
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
    except (OSError, IndexError, ValueError):
        return float("nan")
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def _peak_mb() -> float:
    """This process's peak resident memory so far (ru_maxrss: KB on Linux)."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


# (worker id, its peak MB, its _FOLDER_MEMORY), one per pytest-xdist worker (`make test-cpu` runs two)
_WORKER_MEMORY: list[tuple[str, float, list]] = []


def pytest_sessionfinish(session):
    """In a pytest-xdist worker: hand its memory record to the controller, which prints the summary."""
    out = getattr(session.config, "workeroutput", None)
    if out is not None:
        out["poir_memory"] = {"peak_mb": _peak_mb(), "folders": _FOLDER_MEMORY}
        out["poir_compile"] = _COMPILE


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error):
    """In pytest-xdist's controller: keep each worker's memory record as it ends."""
    out = getattr(node, "workeroutput", {})
    rec = out.get("poir_memory")
    if rec:
        _WORKER_MEMORY.append((node.gateway.id, rec["peak_mb"], [tuple(row) for row in rec["folders"]]))
    for file, row in out.get("poir_compile", {}).items():
        _COMPILE[file] = [a + b for a, b in zip(_COMPILE.get(file, [0.0, 0.0, 0, 0]), row)]


# seconds in tests (setup, call, teardown) per pytest-xdist worker, summed in the controller: how evenly they shared out
_WORKER_BUSY: dict[str, float] = {}


def pytest_runtest_logreport(report):
    node = getattr(report, "node", None)  # set in the controller for a worker's report
    if node is not None:
        who = node.gateway.id
        _WORKER_BUSY[who] = _WORKER_BUSY.get(who, 0.0) + report.duration


def pytest_terminal_summary(terminalreporter):
    """The suite's peak memory and the folders that raised it (per worker under pytest-xdist), so a regression of
    issue 43's class 9 shows in CI."""
    records = sorted(_WORKER_MEMORY)
    if not records and _FOLDER_MEMORY:
        records = [("this pytest process", _peak_mb(), _FOLDER_MEMORY)]
    for who, peak_mb, folders in records:
        _memory_summary(terminalreporter.write_line, who, peak_mb, folders)
    if _WORKER_BUSY:
        terminalreporter.write_line("time in tests per worker: " + ", ".join(
            f"{who} {secs / 60:.1f} min" for who, secs in sorted(_WORKER_BUSY.items())))  # fmt: skip
    _compile_summary(terminalreporter.write_line, _COMPILE)


def _compile_summary(write, per_file: dict, top: int = 12) -> None:
    """The test files whose XLA programs cost most to compile: with an empty cache the suite's time is mostly this."""
    rows = sorted(((b + saved, b, saved, n - hits, hits, f) for f, (b, saved, n, hits) in per_file.items()), reverse=True)
    total = sum(r[0] for r in rows)
    if total < 1:
        return
    write(f"XLA compilation, {total / 60:.1f} min with an empty cache ({sum(r[1] for r in rows) / 60:.1f} min spent here, "
          f"the rest read from the persistent cache); the costliest test files:")  # fmt: skip
    for cold, spent, _, compiled, hits, file in [r for r in rows if r[0] >= 1][:top]:
        write(f"  {file}: {cold:.0f} s ({compiled} programs compiled in {spent:.0f} s, {hits} read from the cache)")


def _memory_summary(write, who: str, peak_mb: float, folders: list) -> None:
    rows, last_peak = [], 0.0
    for folder, end, after, peak in folders:
        rows.append((peak - last_peak, folder, end, after, peak))
        last_peak = max(last_peak, peak)
    write(f"peak resident memory of {who}: {peak_mb / 1024:.1f} GB; folders that raised it:")
    for raised, folder, end, after, peak in sorted(rows, reverse=True)[:6]:
        if raised > 0:
            write(f"  {folder}: peak +{raised:.0f} MB to {peak:.0f} MB; resident {end:.0f} MB at its end, "
                  f"{after:.0f} MB after dropping its programs")  # fmt: skip


def _drop_compiled_programs() -> None:
    import functools
    import gc
    import inspect

    import jax

    for name, module in list(sys.modules.items()):
        if not name.startswith("poir_mjx"):
            continue
        for value in list(vars(module).values()):
            builder = inspect.isfunction(value) and hasattr(value, "cache_clear")  # poir_mjx.cached.builder
            if builder or isinstance(value, functools._lru_cache_wrapper):
                value.cache_clear()
    jax.clear_caches()
    gc.collect()
    if sys.platform.startswith("linux"):  # hand the freed pages back to the OS (glibc keeps them otherwise)
        import ctypes

        try:
            ctypes.CDLL("libc.so.6").malloc_trim(0)
        except (OSError, AttributeError):
            pass
