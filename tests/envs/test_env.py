"""MJX environments: fidelity against robosuite's MuJoCo, batching, bad input, divergence.

Per task and precision only two functions are compiled (batched ``reset_to`` and batched ``step``,
batch 2), shared by every test below: in the fidelity replay lane 0 replays robosuite's episode and
lane 1 is a random reset. Everything runs in float32, the precision `make sweep` uses, except
NutAssemblySquare's fidelity replay (float64: see FLOAT64_FIDELITY).
"""

import contextlib
import functools

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

from poir_mjx.compat import enable_x64
from poir_mjx.envs.env import batched, make_env, make_params
from poir_mjx.envs.reference import robosuite_grasp_rollout
from poir_mjx.envs.tasks import TASKS, UnknownTaskError

# In float32 MJX's contact solve launched Square's 16 g nut during this grasp, which robosuite and
# MJX in float64 both complete (envs/README.md, "Precision"): its replay runs in float64.
FLOAT64_FIDELITY = ("nut_assembly_square",)
# Tolerances (metres, max over the 90-step grasp-and-lift replay, every step). Before the fingers
# touch the object the two simulators agree to micrometres; contact on the simplified geometry
# (prism can, box palm, MJX's convex collision) then shifts the grasp by millimetres. Measured on the
# 2-core CPU (Lift and Can in float32, Square in float64), end effector / object: Lift 0.28 / 0.75 mm,
# Can 12.0 / 4.6 mm, Square 5.9 / 6.9 mm. The bounds leave margin and stay under the scale that
# decides a grasp (finger pad 16 mm, objects 3-8 cm); the object must also rise by more than 5 cm in
# both simulators and the success flag must agree at every step.
EEF_TOL = {"lift": 2e-3, "pick_place_can": 2e-2, "nut_assembly_square": 1e-2}
OBJ_TOL = {"lift": 5e-3, "pick_place_can": 1.5e-2, "nut_assembly_square": 1e-2}
# During the script's approach (steps 0-24, above the object) nothing touches anything.
PRE_CONTACT_STEPS, PRE_CONTACT_TOL = 25, 2e-3


@functools.lru_cache(maxsize=None)
def robosuite_rollout(task):
    """robosuite's grasp-and-lift rollout (seed 1), recorded once per task whatever MJX physics replays it."""
    return robosuite_grasp_rollout(task, make_env(task).mj_model, seed=1)


@functools.lru_cache(maxsize=None)
def replay(task, physics=None):
    """robosuite's rollout and the same actions replayed in MJX (lane 0) beside a random episode, with MJX's
    `physics` (a poir_mjx.envs.physics.PhysicsConfig or preset name; None: the reference)."""
    with enable_x64() if task in FLOAT64_FIDELITY else contextlib.nullcontext():
        return _replay(task, physics)


def _replay(task, physics):
    env = make_env(task, physics=physics)
    _, reset_to, step = batched(task, physics=physics)
    ref = robosuite_rollout(task)
    params = make_params([0.0, 0.3], [0.0, 0.1])
    rand_qpos = jax.jit(jax.vmap(env.sample_qpos))(jax.random.split(jax.random.PRNGKey(3), 2), params)
    qpos = jnp.stack([jnp.asarray(ref.qpos0, rand_qpos.dtype), rand_qpos[1]])
    state = reset_to(qpos, jax.random.split(jax.random.PRNGKey(4), 2), params)
    first_obs = jax.tree_util.tree_map(np.asarray, state.obs)
    eef, obj, succ, objobs = [], [], [], []
    for a in ref.actions:
        state = step(state, jnp.tile(jnp.asarray(a, rand_qpos.dtype), (2, 1)))
        objobs.append(np.asarray(state.obs["object"]))
        eef.append(np.asarray(state.obs["robot0_eef_pos"]))
        obj.append(np.asarray(state.data.xpos[:, env._idx["obj_body"]]))
        succ.append(np.asarray(state.success))
    return ref, first_obs, np.array(objobs), np.array(eef), np.array(obj), np.array(succ), state


# The cheaper physics (poir_mjx/envs/physics.py) is held to the same tolerances: "fast" on Lift, "fast-capped" on
# PickPlaceCan, whose contacts the cap bounds (the other figures: results/bench/physics-cpu*.md).
@pytest.mark.slow
@pytest.mark.needs_robosuite
@pytest.mark.parametrize("task, physics", [(t, None) for t in TASKS] + [("lift", "fast"), ("pick_place_can", "fast-capped")])
def test_fidelity_against_robosuite(task, physics):
    ref, first_obs, objobs, eef, obj, succ, _ = replay(task, physics)
    # The same robomimic "object" vector as robosuite at reset and after the first step (no contact
    # yet; objects still settle after being dropped by the placement sampler: 0.25 mm seen on Can).
    np.testing.assert_allclose(first_obs["object"][0], ref.object_obs[0], atol=1e-5)
    np.testing.assert_allclose(objobs[0, 0], ref.object_obs[1], atol=1e-3)
    pre = np.abs(eef[:PRE_CONTACT_STEPS, 0] - ref.eef_pos[:PRE_CONTACT_STEPS]).max()
    assert pre < PRE_CONTACT_TOL, pre
    eef_err = np.abs(eef[:, 0] - ref.eef_pos).max()
    obj_err = np.abs(obj[:, 0] - ref.obj_pos).max()
    print(f"{task} ({physics or 'reference'} physics): max eef error {eef_err:.2e} m, max object error {obj_err:.2e} m")
    assert eef_err < EEF_TOL[task]
    assert obj_err < OBJ_TOL[task]
    # The script closes the gripper on the object and lifts it: it must actually rise in both.
    assert ref.obj_pos[-1, 2] - ref.obj_pos[0, 2] > 0.05
    assert obj[-1, 0, 2] - obj[0, 0, 2] > 0.05
    np.testing.assert_array_equal(succ[:, 0], ref.success)


# Few steps: on jax 0.11.2's CPU backend (the current dependency set) a PickPlaceCan control step
# takes about 15 s at batch 2 (0.4 s on jax 0.7.0), see README "Dependencies".
ROLLOUT_STEPS = 5


@pytest.mark.slow
@pytest.mark.current_stack
@pytest.mark.parametrize("task", TASKS)
def test_float32_batch_rollout_is_finite_with_right_shapes(task):
    """5 control steps of two float32 episodes (sigma_init 0.02 and 0.3) under random actions, no robosuite."""
    env = make_env(task)
    reset, _, step = batched(task)
    params = make_params([0.02, 0.3], [0.0, 0.1])
    state = reset(jax.random.split(jax.random.PRNGKey(0), 2), params)
    assert state.data.qpos.dtype == jnp.float32
    actions = jax.random.uniform(jax.random.PRNGKey(1), (ROLLOUT_STEPS, 2, 7), minval=-1, maxval=1)
    start = np.asarray(state.obs["robot0_eef_pos"])
    for a in actions:
        state = step(state, a)
    sizes = env.obs_sizes
    assert sizes["object"] == (10 if task == "lift" else 14)
    for k, v in state.obs.items():
        assert v.shape == (2, sizes[k]), k
        assert np.all(np.isfinite(np.asarray(v))), k
    assert state.info["step"].tolist() == [ROLLOUT_STEPS, ROLLOUT_STEPS]
    assert not np.any(np.asarray(state.info["diverged"]))
    assert np.all(np.linalg.norm(np.asarray(state.obs["robot0_eef_pos"]) - start, axis=-1) > 1e-3)  # the arm moved
    if task == "lift":  # robosuite redraws the cube's size at every reset; so does the MJX Lift
        v = np.asarray(state.info["variant"])
        half_z = np.asarray(env.variants.sizes)[v, 2]
        bottom = np.asarray(state.data.xpos[:, env._idx["obj_body"], 2]) - half_z
        assert v[0] != v[1] and half_z[0] != half_z[1]
        np.testing.assert_allclose(bottom, env.meta["success"]["table_height"], atol=2e-3)  # resting on the table


@pytest.mark.slow
def test_nan_in_one_episode_does_not_poison_the_batch():
    task = "lift"
    env = make_env(task)
    _, reset_to, step = batched(task)
    params = make_params([0.02, 0.02])
    qpos = jax.jit(jax.vmap(env.sample_qpos))(jax.random.split(jax.random.PRNGKey(0), 2), params)
    state = reset_to(qpos, jax.random.split(jax.random.PRNGKey(1), 2), params)
    bad = state.replace(data=state.data.replace(qvel=state.data.qvel.at[1, 0].set(jnp.nan)))
    out = step(bad, jnp.zeros((2, 7)))
    assert out.info["diverged"].tolist() == [False, True]
    assert out.done.tolist() == [False, True]
    assert not bool(out.success[1])
    assert np.all(np.isfinite(np.asarray(out.obs["object"][0])))
    out2 = step(out, jnp.zeros((2, 7)))  # the flagged episode stays frozen and flagged
    assert out2.info["step"].tolist() == [2, 0]
    assert out2.info["diverged"].tolist() == [False, True]


def test_sigma_zero_is_exact_and_noise_is_per_episode():
    env = make_env("lift")
    p0 = make_params(0.0, 0.0)
    q = np.asarray(env.sample_qpos(jax.random.PRNGKey(0), p0))
    np.testing.assert_array_equal(q[env._idx["arm_qpos"]], np.asarray(env.meta["init_qpos"], q.dtype))
    params = make_params([0.1, 0.1])
    qs = np.asarray(jax.vmap(env.sample_qpos)(jax.random.split(jax.random.PRNGKey(0), 2), params))
    assert not np.allclose(qs[0], qs[1])


def test_bad_input_is_a_clear_error():
    env = make_env("lift")
    with pytest.raises(ValueError, match="sigma_init"):
        make_params(-0.1)
    with pytest.raises(ValueError, match="sigma_action"):
        make_params(0.02, float("nan"))
    with pytest.raises(UnknownTaskError, match="task"):
        make_env("Door")
    state = None  # shape/dtype checks happen before any physics is traced
    with pytest.raises(ValueError, match=r"action: expected shape \(7,\)"):
        env.step(state, jnp.zeros(6))
    with pytest.raises(ValueError, match="action: expected a floating-point dtype"):
        env.step(state, jnp.zeros(7, jnp.int32))


def test_lift_size_variants_are_mujocos_own_models():
    """Variant 0 is the exported model; the others are robosuite's size range compiled by MuJoCo (density kept)."""
    env = make_env("lift")
    v = env.variants
    sizes = np.asarray(v.sizes)
    assert v.count == 16 and np.all(sizes[1:] >= 0.020) and np.all(sizes[1:] <= 0.022)
    g = mujoco.mj_name2id(env.mj_model, mujoco.mjtObj.mjOBJ_GEOM, "cube_g0")
    b = env._idx["obj_body"]
    np.testing.assert_allclose(sizes[0], env.mj_model.geom_size[g])
    m0, m3 = v.model(0), v.model(3)
    np.testing.assert_array_equal(np.asarray(m0.geom_size), np.asarray(env.model.geom_size))
    np.testing.assert_allclose(np.asarray(m3.geom_size)[g], sizes[3], rtol=1e-6)
    np.testing.assert_allclose(np.asarray(m3.body_mass)[b], 1000.0 * 8 * np.prod(sizes[3]), rtol=1e-5)
    assert make_env("pick_place_can").variants is None  # fixed-size objects
