"""Lift in MJX: its replay of robosuite's grasp-and-lift within the fidelity tolerances (float32, the reference
physics and "fast"), and a float32 batch rollout. One file per task, so the suite's two pytest-xdist workers share
the tasks out; a file's tests share its compiled programs (tests/helpers.py: ``replay``)."""

from tests.helpers import task_tests

test_fidelity_against_robosuite, test_float32_batch_rollout_is_finite_with_right_shapes = task_tests(
    "lift", [None, "fast"]
)
