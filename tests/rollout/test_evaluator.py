"""Episode keys of a cell batch (poir_mjx/rollout/evaluator.py): what pairs cells within and across sweeps."""

import numpy as np

from poir_mjx.rollout.evaluator import episode_keys


def test_a_cell_keeps_its_episodes_when_later_cells_are_added():
    # docs/evaluation.md: cell j of a grid takes keys j*E..(j+1)*E, so two sweeps share a cell's episodes exactly
    # when it sits at the same grid position (a longer grid does not change the earlier cells' keys).
    e = 5
    two, four = np.asarray(episode_keys(0, 2 * e)), np.asarray(episode_keys(0, 4 * e))
    np.testing.assert_array_equal(two, four[:2 * e])
    assert not np.array_equal(two[e:], four[3 * e:])  # the same noise level at another position: other episodes
    assert len({tuple(k) for k in four}) == 4 * e
    assert not np.array_equal(np.asarray(episode_keys(1, 2 * e)), two)  # the training seed changes every episode
