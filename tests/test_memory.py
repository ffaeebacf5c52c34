"""The suite's memory (issue 43, class 9): the compiled programs a test folder kept alive are dropped before the next
folder's tests, so the process does not grow with every folder."""

import dataclasses
from pathlib import Path
from types import SimpleNamespace

from poir_mjx.core.agent import POIR
from poir_mjx.diagnose import probe
from tests import conftest
from tests.helpers import SMALL


def test_a_new_test_folder_starts_without_the_last_folders_compiled_programs():
    fn = probe.one_step_error_fn
    fn(POIR(dataclasses.replace(SMALL, ensemble_size=2), 2, 2))  # a memoised builder holding a jitted function
    assert fn.cache_info().currsize >= 1
    here = SimpleNamespace(path=Path(__file__))
    conftest.pytest_runtest_teardown(here, SimpleNamespace(path=Path(__file__)))  # same folder next: kept
    assert fn.cache_info().currsize >= 1
    conftest.pytest_runtest_teardown(here, SimpleNamespace(path=Path(__file__).parent / "core" / "test_x.py"))
    assert fn.cache_info().currsize == 0


def test_each_xdist_workers_memory_is_summarised_by_the_controller(monkeypatch):
    rows = [("tests/envs", 900.0, 100.0, 1000.0)]
    worker = SimpleNamespace(config=SimpleNamespace(workeroutput={}))
    monkeypatch.setattr(conftest, "_FOLDER_MEMORY", rows)
    conftest.pytest_sessionfinish(worker)  # in the worker: its record goes into workeroutput
    node = SimpleNamespace(gateway=SimpleNamespace(id="gw1"), workeroutput=worker.config.workeroutput)
    monkeypatch.setattr(conftest, "_WORKER_MEMORY", [])
    conftest.pytest_testnodedown(node, None)  # in the controller
    lines = []
    conftest.pytest_terminal_summary(SimpleNamespace(write_line=lines.append))
    assert lines[0].startswith("peak resident memory of gw1:")
    assert lines[1].startswith("  tests/envs: peak +1000 MB")


def test_the_longest_files_run_first_and_exist(pytestconfig):
    """`make test-cpu` hands files to its two workers in collection order: the long ones must come first."""
    root = Path(__file__).parent.parent
    assert all((root / path).is_file() for path in conftest.LONGEST_FIRST)
    items = [SimpleNamespace(path=root / p, keywords={}) for p in
             ["tests/test_memory.py", conftest.LONGEST_FIRST[1], "tests/core/test_prior.py", conftest.LONGEST_FIRST[0]]]
    conftest.pytest_collection_modifyitems(pytestconfig, items)
    assert [conftest._suite_path(i) for i in items] == [*conftest.LONGEST_FIRST[:2], "tests/test_memory.py",
                                                         "tests/core/test_prior.py"]  # fmt: skip


def test_compile_time_is_charged_to_the_running_test_file(monkeypatch):
    monkeypatch.setattr(conftest, "_COMPILE", {})
    conftest.pytest_runtest_setup(SimpleNamespace(path=Path(__file__)))
    conftest._record_compile(conftest._BACKEND_COMPILE, 3.0, fun_name="step")
    conftest._record_compile(conftest._BACKEND_COMPILE, 0.5, fun_name="step")  # a cache hit's read...
    conftest._record_compile(conftest._CACHE_SAVED, 90.0)  # ...and the compile time it saved
    conftest._record_compile("/jax/core/compile/jaxpr_trace_duration", 7.0)  # not a compilation
    assert conftest._COMPILE == {"tests/test_memory.py": [3.5, 90.0, 2, 1]}
    lines = []
    conftest._compile_summary(lines.append, conftest._COMPILE)
    assert lines[0].startswith("XLA compilation, 1.6 min with an empty cache (0.1 min spent here")
    assert lines[1] == "  tests/test_memory.py: 94 s (1 programs compiled in 4 s, 1 read from the cache)"
