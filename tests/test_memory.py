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
