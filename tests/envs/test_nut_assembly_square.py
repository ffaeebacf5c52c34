"""NutAssemblySquare in MJX: its replay of robosuite's grasp-and-lift within the fidelity tolerances (the
reference physics in float64: in float32 MJX's contact solve launched the 16 g nut), and a float32 batch rollout.
One file per task, so the suite's two pytest-xdist workers share the tasks out (tests/helpers.py: ``replay``)."""

import pytest

from tests.helpers import assert_batch_rollout, assert_fidelity

TASK = "nut_assembly_square"


@pytest.mark.slow
@pytest.mark.needs_robosuite
@pytest.mark.parametrize("physics", [None])
def test_fidelity_against_robosuite(physics):
    assert_fidelity(TASK, physics)


@pytest.mark.slow
@pytest.mark.current_stack
def test_float32_batch_rollout_is_finite_with_right_shapes():
    assert_batch_rollout(TASK)
