"""The named rankings: "balanced" (the default) is head-balanced selection and L2 without the quaternions; "paper"
is the planner as printed."""

import dataclasses

import pytest

from poir_mjx.core.config import preset
from poir_mjx.core.ranking import DEFAULT_RANKING, quaternion_free, with_ranking
from poir_mjx.envs.layout import obs_groups
from poir_mjx.envs.tasks import TASKS

LOW_DIM_NO_QUATERNIONS = (0, 1, 2, 7, 8, 9, 10, 11, 16, 17, 18)  # the hand's and object's positions, the fingers


def test_balanced_is_head_balanced_selection_and_l2_without_quaternions_and_nothing_else():
    base = preset("cpu-small")
    cfg = with_ranking(base, "balanced", obs_groups("lift"))
    assert DEFAULT_RANKING == "balanced"
    assert (cfg.planner.selection, cfg.planner.l2_dims) == ("head_balanced", LOW_DIM_NO_QUATERNIONS)
    assert dataclasses.replace(cfg, planner=base.planner) == base
    assert dataclasses.replace(cfg.planner, selection="top_k", l2_dims=()) == base.planner
    assert with_ranking(base, "paper", obs_groups("lift")) == base
    with pytest.raises(ValueError, match="ranking: 'best'"):
        with_ranking(base, "best", obs_groups("lift"))


@pytest.mark.parametrize("observation, expected", [("low_dim", LOW_DIM_NO_QUATERNIONS), ("object", (0, 1, 2, 7, 8, 9))])
def test_the_quaternion_free_dimensions_are_every_tasks_non_quaternion_ones(observation, expected):
    for task in TASKS:
        groups = obs_groups(task, observation=observation)
        assert quaternion_free(groups) == expected, task
        assert [g for i, g in enumerate(groups) if i not in expected] == ["quaternion"] * (len(groups) - len(expected))
