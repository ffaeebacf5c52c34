"""The paper's observation (robosuite's object-state vector alone): its layout, and the MJX and robosuite
environments giving the policy the same vector for the same state."""

import jax
import numpy as np
import pytest

from poir_mjx.envs.env import make_env
from poir_mjx.envs.layout import OBS_KEYS, obs_groups, observation_keys, observation_named
from poir_mjx.envs.tasks import TASKS

OBJECT_SIZE = {"lift": 10, "pick_place_can": 14, "nut_assembly_square": 14}


@pytest.mark.parametrize("task", TASKS)
def test_object_observation_is_the_object_state_alone(task):
    low, obj = obs_groups(task), obs_groups(task, observation="object")
    assert len(obj) == OBJECT_SIZE[task] and len(low) == OBJECT_SIZE[task] + 9
    assert obj == low[9:]  # the object-state's groups, as the low-dim vector has them after the robot's
    assert observation_keys("low_dim") == OBS_KEYS and observation_keys("object") == ("object",)
    assert observation_named(["object"]) == "object" and observation_named(list(OBS_KEYS)) == "low_dim"
    assert observation_named(["robot0_eef_pos"]) is None
    env = make_env(task, observation="object")
    assert env.obs_size == OBJECT_SIZE[task] and make_env(task).obs_size == OBJECT_SIZE[task] + 9
    assert env.model is make_env(task).model  # one compiled model per task, whatever the observation
    with pytest.raises(ValueError, match="observation: 'joints' is not one of"):
        make_env(task, observation="joints")


@pytest.mark.slow
@pytest.mark.needs_robosuite
@pytest.mark.parametrize("task", TASKS)
def test_mjx_and_robosuite_give_the_same_object_observation_for_the_same_state(task):
    """robosuite's reset state put into MJX: the MJX environment's policy vector (env.obs_vector) and the robosuite
    worker's (flat_obs) agree, for the object-state alone and for the low-dim set it ends. Only the reset is compiled
    (about 20 s per task on the 2-core CPU with a warm cache); the per-task fidelity replays (test_lift.py ...) compare the
    object-state over 90 steps."""
    from poir_mjx.envs.reference import qpos_from_robosuite
    from poir_mjx.envs.tasks import make_robosuite
    from poir_mjx.eval.robosuite_worker import flat_obs

    rs = make_robosuite(task, seed=1)
    o = rs.reset()
    low = make_env(task)
    env = make_env(task, observation="object")
    qpos = qpos_from_robosuite(rs, low.mj_model)
    rs.close()
    state = jax.jit(lambda q: env.reset_to(q, jax.random.PRNGKey(0), _params()))(qpos)
    mjx_obj, mjx_low = np.asarray(env.obs_vector(state)), np.asarray(low.obs_vector(state))
    rs_obj, rs_low = flat_obs(o, "object"), flat_obs(o)
    assert mjx_obj.shape == rs_obj.shape == (OBJECT_SIZE[task],)
    np.testing.assert_allclose(mjx_obj, rs_obj, atol=1e-5)
    np.testing.assert_allclose(mjx_low[9:], mjx_obj, atol=0)
    np.testing.assert_allclose(rs_low[9:], rs_obj, atol=0)
    np.testing.assert_allclose(mjx_low[:3], rs_low[:3], atol=1e-5)  # the same hand: the same state


def _params():
    from poir_mjx.envs.env import make_params

    return make_params(0.0, 0.0)
