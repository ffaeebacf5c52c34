"""How each episode ended (poir_mjx/eval/outcomes.py): the labels from hand and object positions, on synthetic
observations (the robosuite collection test checks them on real episodes)."""

import numpy as np
import pytest

from poir_mjx.eval import outcomes as oc


def test_the_hand_and_object_positions_are_found_per_task():
    assert oc.position_slices("lift") == (slice(0, 3), slice(9, 12))  # cube_pos first among the object's keys
    # PickPlaceCan and Square list the object-to-hand pose first: the object's own position comes after it (3 + 4)
    assert oc.position_slices("pick_place_can") == (slice(0, 3), slice(16, 19))
    assert oc.position_slices("nut_assembly_square") == (slice(0, 3), slice(16, 19))
    assert oc.position_slices("lift", "object") is None  # no hand position in the object-state alone


def _episode(hand, obj, d=19):
    """Observations [T, d] with the hand at `hand` [T, 3] and the object at `obj` [T, 3] (Lift's layout)."""
    o = np.zeros((len(hand), d))
    o[:, 0:3], o[:, 9:12] = hand, obj
    return o


@pytest.mark.parametrize("end, moving, label", [
    ((0.5, 0.0, 0.0), False, "ran_away"),
    ((0.02, 0.0, 0.0), False, "stalled_at_object"),
    ((0.15, 0.0, 0.0), False, "stalled_elsewhere"),
    ((0.02, 0.0, 0.0), True, "moving_near_object"),
])  # fmt: skip
def test_a_failed_episode_is_labelled_by_where_the_hand_ends_and_whether_it_rests(end, moving, label):
    T = 120
    hand = np.linspace((0.3, 0.3, 0.3), end, T)
    hand[-oc.REST_STEPS:] = end  # at rest for the last REST_STEPS steps ...
    if moving:  # ... unless it keeps circling 2 cm around its end point
        t = np.arange(oc.REST_STEPS)
        hand[-oc.REST_STEPS:] += 0.02 * np.stack([np.cos(t), np.sin(t), 0 * t], 1)
    obs = _episode(hand, np.zeros((T, 3)))
    tr = oc.OutcomeTracker(1, oc.position_slices("lift"))
    tr.begin(np.array([0]), obs[:1])
    for t in range(1, T):
        tr.observe(np.array([0]), obs[t : t + 1])
    labels, moved = tr.labels(np.array([-1]), np.array([False]))
    assert labels == [label] and not moved[0]


def test_success_and_divergence_come_first_and_moved_object_counts_failures_that_pushed_or_raised_it():
    T, n = 80, 5
    tr = oc.OutcomeTracker(n, oc.position_slices("lift"))
    rows = np.arange(n)
    hand = np.zeros((n, 3))
    for t in range(T):
        obj = np.zeros((n, 3))
        obj[:3, 2] = 0.03 * t / T  # three objects rise 3 cm
        obj[3, 0] = 0.02 * t / T  # one is pushed 2 cm sideways
        obj[4, 2] = -0.01 * min(t, 5) / 5  # one drops 1 cm as it settles (Lift's cube at reset): not a move
        obs = np.concatenate([_episode(hand[i : i + 1], obj[i : i + 1]) for i in range(n)])
        (tr.begin if t == 0 else tr.observe)(rows, obs)
    labels, moved = tr.labels(np.array([40, -1, -1, -1, -1]), np.array([False, True, False, False, False]))
    assert labels == ["success", "diverged", "stalled_at_object", "stalled_at_object", "stalled_at_object"]
    assert moved.tolist() == [False, True, True, True, False]  # a success is not a failure that moved it
    s = oc.summary(labels, moved)
    assert s == {"success": 1, "diverged": 1, "ran_away": 0, "stalled_at_object": 3, "stalled_elsewhere": 0,
                 "moving_near_object": 0, "moved_object": 3}  # fmt: skip


def test_an_episode_shorter_than_the_rest_window_is_never_at_rest():
    tr = oc.OutcomeTracker(1, oc.position_slices("lift"))
    obs = _episode(np.full((5, 3), 0.02), np.zeros((5, 3)))
    tr.begin(np.array([0]), obs[:1])
    for t in range(1, 5):
        tr.observe(np.array([0]), obs[t : t + 1])
    assert tr.labels(np.array([-1]), np.array([False]))[0] == ["moving_near_object"]
