"""NutAssemblySquare in MJX: its replay of robosuite's grasp-and-lift within the fidelity tolerances (the
reference physics in float64: in float32 MJX's contact solve launched the 16 g nut), and a float32 batch rollout.
One file per task, so the suite's two pytest-xdist workers share the tasks out (tests/helpers.py: ``replay``)."""

from tests.helpers import task_tests

test_fidelity_against_robosuite, test_float32_batch_rollout_is_finite_with_right_shapes = task_tests(
    "nut_assembly_square", [None]
)
