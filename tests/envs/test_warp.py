"""MuJoCo Warp as the environment's physics (``physics: warp``), on the CPU at tiny sizes (make test-warp: the
current set plus warp-lang). Warp compiles its CPU kernels once per machine (about a minute, cached in
~/.cache/warp); a Lift control step then takes about 0.6 s at batch 2."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx.envs.env import batched, make_env, make_params
from poir_mjx.envs.physics import PhysicsConfig
from poir_mjx.envs.reference import GRASP_SCRIPT_STEPS, grasp_and_lift_action
from poir_mjx.envs.warp import jax_sizes
from poir_mjx.rollout.episode import batched_episodes, stateless

pytestmark = pytest.mark.needs_warp

BATCH = 2


def grasp_and_lift(physics):
    """The fidelity test's grasp-and-lift script, closed loop in MJX at batch 2 (sigma_init 0.02 and 0.1) ->
    end-effector and cube positions [T, B, 3]."""
    env = make_env("lift", physics=physics)
    reset, _, step = batched("lift", physics=physics)
    state = reset(jax.random.split(jax.random.PRNGKey(3), BATCH), make_params([0.02, 0.1], [0.0, 0.0]))
    body = env._idx["obj_body"]
    eef, cube = [], []
    for t in range(GRASP_SCRIPT_STEPS):
        pos = np.asarray(state.obs["robot0_eef_pos"])
        if t < 45:  # track the cube until the gripper closes, as the robosuite reference does
            target = np.asarray(state.data.xpos[:, body])
        act = np.stack([grasp_and_lift_action(t, pos[b], target[b]) for b in range(BATCH)])
        state = step(state, jnp.asarray(act, jnp.float32))
        eef.append(np.asarray(state.obs["robot0_eef_pos"]))
        cube.append(np.asarray(state.data.xpos[:, body]))
    return np.array(eef), np.array(cube), state


def test_warp_grasps_and_lifts_as_the_jax_pipeline_does():
    eef_w, cube_w, state = grasp_and_lift("warp")
    eef_j, cube_j, _ = grasp_and_lift(PhysicsConfig(floor_contacts=False))  # the same model, MJX's JAX pipeline
    assert not np.asarray(state.info["diverged"]).any()
    lifted = cube_w[-1, :, 2] - cube_w[0, :, 2]
    assert (lifted > 0.1).all(), lifted  # both episodes hold the cube 10+ cm up
    assert np.asarray(state.success).all()
    # the same contacts resolved by another solver implementation: within a millimetre all along
    assert np.abs(eef_w - eef_j).max() < 1e-3, np.abs(eef_w - eef_j).max()
    assert np.abs(cube_w - cube_j).max() < 1e-3, np.abs(cube_w - cube_j).max()


def test_contact_buffers_belong_to_the_batch_and_finished_episodes_stay_put():
    env = make_env("lift", physics="warp")
    _, per_world = jax_sizes(env.mj_model)
    reset, _, step = batched("lift", physics="warp")
    state = reset(jax.random.split(jax.random.PRNGKey(0), 3), make_params([0.02] * 3, [0.0] * 3))
    assert state.data._impl.contact__pos.shape[0] == 3 * per_world  # shared by the three worlds, no batch axis
    assert state.data.qpos.shape[0] == 3
    done = state.replace(done=jnp.array([True, False, False]))
    nxt = step(done, jnp.tile(jnp.array([0.5, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0]), (3, 1)))
    np.testing.assert_array_equal(np.asarray(nxt.data.qpos[0]), np.asarray(state.data.qpos[0]))
    assert np.abs(np.asarray(nxt.data.qpos[1:] - state.data.qpos[1:])).max() > 1e-4
    assert nxt.data._impl.contact__pos.shape[0] == 3 * per_world


def test_batched_episodes_size_the_environment_for_their_batch():
    """The rollout layer (evaluator, MJX demos, online collection, videos) sizes Warp's buffers from the batch it is
    traced with: two batch sizes, two sizings, the same per-episode results for the shared episodes."""
    env = make_env("lift", physics="warp")
    policy = stateless(env, lambda params, obs, key: jnp.array([0.0, 0.0, -0.3, 0.0, 0.0, 0.0, -1.0]))
    run = batched_episodes(env, policy, steps=2, record=lambda s, a, n: n.obs["robot0_eef_pos"])
    keys = jax.random.split(jax.random.PRNGKey(1), 3)
    out3, eef3 = run(None, keys, make_params([0.02] * 3, [0.0] * 3))
    out1, eef1 = run(None, keys[:1], make_params([0.02], [0.0]))
    assert eef3.shape == (3, 2, 3) and out3["steps"].tolist() == [2, 2, 2]
    np.testing.assert_allclose(np.asarray(eef1[0]), np.asarray(eef3[0]), atol=1e-6)
    assert env.sized_for(3).worlds == 3 and env.sized_for(3) is env.sized_for(3)


def test_the_gpu_checks_warp_stage_times_it(tmp_path):
    """The GPU check's last stage (where warp-lang was carried in parts): its dry run, here on the CPU."""
    import json

    from poir_mjx.gpucheck.runner import run_stage

    run_stage("warp", True, tmp_path / "gpu", tmp_path / "scratch")
    rows = json.loads((tmp_path / "gpu" / "warp.json").read_text())["rows"]
    assert [(r["physics"], r["batch"]) for r in rows] == [("warp", 1)]
    assert rows[0]["control_steps_per_s"] > 0 and rows[0]["diverged"] == 0
