"""The MJX solver patch (poir_mjx/envs/solver_patch.py): the same physics as MJX's own solver, scoped to the
environments that ask for it, refused on an MJX it was not written for.

The equality test replays robosuite's Lift grasp-and-lift actions (tests/helpers.py's ``replay``, batch 2, the 90
steps test_lift.py's fidelity test replays) with the "same-maths" physics and without: one patched program, not one
per patch (each costs minutes to compile on CPU; "fast" in test_lift.py runs both patches too, against robosuite).
"""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx.envs import solver_patch
from poir_mjx.envs.env import make_env
from poir_mjx.envs.physics import REFERENCE
from tests.helpers import replay

WHILE = dataclasses.replace(REFERENCE, linesearch_loop="while")
# float32 tolerance of a patched replay against the unpatched one (metres, max over both lanes). The patch
# computes the same operations, compiled differently; float32 rounding then differs and the grasp (lane 0
# closes the fingers on the cube at steps 45-55) amplifies it. Measured on the 2-core CPU: MJX's own step
# compiled at batch 1 and at batch 2 differs by 0.031 mm (end effector) / 0.12 mm (object) on this replay; the
# while line search against the scan 0.066 / 0.17 mm, and 0 / 5.5e-7 m before the grasp; "same-maths" 0.18 mm (max
# of the two), 1.0e-6 m before the grasp (2026-12-07). The bounds: before
# the grasp (steps < PRE_GRASP_STEPS) 10 micrometres, over all 90 steps 0.5 mm (the fidelity test allows 2 mm /
# 5 mm against robosuite).
PRE_GRASP_STEPS, PRE_GRASP_TOL = 50, 1e-5
EQUAL_TOL = 5e-4


def test_while_loop_bounded_matches_mjx_scan_under_vmap():
    from mujoco.mjx._src import solver

    def cond(v):
        return v[1] > 0.01

    def body(v):
        return v[0] + 1, v[1] * 0.5

    init = (jnp.zeros(4, jnp.int32), jnp.array([0.0, 0.3, 1.0, 1e6]))
    for max_iter in (3, 50):
        ref = jax.vmap(lambda a, b: solver._while_loop_scan(cond, body, (a, b), max_iter))(*init)
        new = jax.vmap(lambda a, b: solver_patch.while_loop_bounded(cond, body, (a, b), max_iter))(*init)
        np.testing.assert_array_equal(ref[0], new[0])
        np.testing.assert_array_equal(ref[1], new[1])
    assert new[0].tolist() == [0, 5, 7, 27]  # converged lanes stop; the last stops at its own condition


def test_patch_is_scoped_to_its_trace():
    from mujoco.mjx._src import solver

    original, gradient = solver._while_loop_scan, solver._update_gradient
    with solver_patch.patched(while_linesearch=True):
        assert solver._while_loop_scan is solver_patch.while_loop_bounded
        assert solver._update_gradient is gradient
    with solver_patch.patched(while_linesearch=False, block_hessian=True):
        assert solver._while_loop_scan is original
        assert solver._update_gradient.func is solver_patch.update_gradient_blocks
    assert (solver._while_loop_scan, solver._update_gradient) == (original, gradient)
    with pytest.raises(RuntimeError), solver_patch.patched(while_linesearch=True):
        raise RuntimeError("restored on errors too")
    assert solver._while_loop_scan is original


def test_refused_on_an_mjx_it_was_not_written_for(monkeypatch):
    solver_patch.check_version("3.3.7")
    solver_patch.check_version("3.17.0")
    with pytest.raises(solver_patch.UnsupportedMJXError, match="written for mujoco-mjx 3.3.7 and 3.17.0, this is 3.2.0"):
        solver_patch.check_version("3.2.0")
    monkeypatch.setattr(solver_patch, "mjx_version", lambda: "3.18.0")
    with pytest.raises(solver_patch.UnsupportedMJXError, match="this is 3.18.0"):
        make_env("lift", physics=WHILE)
    make_env("lift")  # the unpatched reference needs no check


@pytest.mark.slow
@pytest.mark.needs_robosuite
def test_same_maths_step_equals_mjx_on_lift_replay():
    """"same-maths" (the while line search, the cone Hessian per contact block, the floor's pairs dropped) against
    MJX's own solver: the patches and the cut that keep the reference's physics, together."""
    _, _, _, eef0, obj0, succ0, _ = replay("lift")
    _, _, _, eef1, obj1, succ1, end1 = replay("lift", "same-maths")
    assert_same_physics('"same-maths"', (eef0, obj0, succ0), (eef1, obj1, succ1))
    assert not np.any(np.asarray(end1.info["diverged"]))


def assert_same_physics(what, ref, new):
    """Two replays (end effector, object, success per step and lane) agree within float32 tolerance."""
    diff = np.maximum(np.abs(new[0] - ref[0]).max(-1), np.abs(new[1] - ref[1]).max(-1))  # [steps, lanes]
    print(f"lift, {what} vs MJX's own: max eef/object difference {diff[:PRE_GRASP_STEPS].max():.2e} m before the "
          f"grasp, {diff.max():.2e} m over the replay")
    assert diff[:PRE_GRASP_STEPS].max() < PRE_GRASP_TOL
    assert diff.max() < EQUAL_TOL
    np.testing.assert_array_equal(new[2], ref[2])
