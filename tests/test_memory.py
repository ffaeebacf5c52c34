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
    fn(POIR(dataclasses.replace(SMALL, ensemble_size=2), 2, 2))  # an lru-cached builder holding a jitted function
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
