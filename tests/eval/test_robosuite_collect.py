"""Collection in robosuite (online fine-tuning's deployments): the transitions and their validity mask are
the episodes' real ones, and the overlapped (two worker groups) loop runs the same episodes as the plain one."""

import numpy as np
import pytest

from poir_mjx.eval import robosuite_eval
from poir_mjx.rollout.evaluator import episode_keys
from tests.eval.scripted_lift import scripted_lift

pytestmark = pytest.mark.needs_robosuite

STEPS = 70


@pytest.fixture(scope="module")
def collected():
    keys = episode_keys(3, 3)
    sigma_init = np.array([0.02, 0.02, 0.5])
    out, trans = robosuite_eval.collect("lift", scripted_lift, None, keys, sigma_init, 0.0, STEPS, workers=2,
                                        envs_per_worker=1, overlap=True)  # fmt: skip
    plain = robosuite_eval.evaluate("lift", scripted_lift, None, keys, sigma_init, 0.0, STEPS, workers=2,
                                    envs_per_worker=2, progress=False, overlap=False)  # fmt: skip
    return keys, sigma_init, out, trans, plain


def test_overlapped_loop_runs_the_same_episodes(collected):
    _, _, out, _, plain = collected
    np.testing.assert_array_equal(out["first_success"], plain["first_success"])
    first = out["first_success"]
    assert (first > 0).any() and (first < 0).any()  # both ends of the mask are tested: success and time-out


def test_mask_ends_at_success_and_transitions_chain(collected):
    _, _, out, (obs, act, nxt, valid), _ = collected
    assert obs.shape == nxt.shape == (3, STEPS, 19) and act.shape == (3, STEPS, 7) and valid.shape == (3, STEPS)
    for e, first in enumerate(out["first_success"]):
        n_valid = first if first > 0 else STEPS  # the success step is the last valid transition
        assert valid[e, :n_valid].all() and not valid[e, n_valid:].any()
        np.testing.assert_array_equal(nxt[e, : n_valid - 1], obs[e, 1:n_valid])  # s'_t is s_{t+1}
        assert not np.any(obs[e, n_valid:]) and not np.any(act[e, n_valid:])  # nothing recorded after the end


def test_transitions_replay_in_a_fresh_robosuite_environment(collected):
    """Stepping robosuite from the episode's seed with the recorded actions gives the recorded states."""
    from poir_mjx.envs.tasks import make_robosuite
    from poir_mjx.eval.robosuite_worker import flat_obs

    keys, sigma_init, out, (obs, act, nxt, valid), _ = collected
    seeds, _ = robosuite_eval.episode_streams(keys, STEPS)
    e = 0
    env = make_robosuite("lift", seed=int(seeds[e]), initialization_noise={"magnitude": float(sigma_init[e]), "type": "gaussian"})
    np.testing.assert_array_equal(flat_obs(env.reset()), obs[e, 0])
    for t in range(int(valid[e].sum())):
        o, _, _, _ = env.step(act[e, t].astype(np.float64))
        np.testing.assert_allclose(flat_obs(o), nxt[e, t], rtol=0, atol=1e-6)
    env.close()


def test_each_episode_is_labelled_from_its_own_recorded_positions(collected):
    """The outcome labels (eval/outcomes.py) agree with the recorded episode: successes are "success", a failure's
    label follows from where its last recorded hand and object positions are; both loops label alike."""
    from poir_mjx.eval import outcomes as oc

    _, _, out, (obs, _, nxt, valid), plain = collected
    assert out["outcome"] == plain["outcome"]
    hand, obj = oc.position_slices("lift")
    for e, first in enumerate(out["first_success"]):
        if first > 0:
            assert out["outcome"][e] == "success"
            continue
        last = nxt[e, int(valid[e].sum()) - 1]
        dist = np.linalg.norm(last[hand] - last[obj])
        want = {"ran_away"} if dist > oc.RAN_AWAY_M else (
            {"stalled_at_object", "moving_near_object"} if dist < oc.AT_OBJECT_M else
            {"stalled_elsewhere", "moving_near_object"})  # fmt: skip
        assert out["outcome"][e] in want
        d = nxt[e, : int(valid[e].sum()), obj] - obs[e, 0, obj]
        moved = max(np.linalg.norm(d[:, :2], axis=-1).max(), d[:, 2].max())  # pushed sideways or raised
        assert bool(out["moved_object"][e]) == (moved > oc.TOUCH_M)
