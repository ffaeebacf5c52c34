"""MJX environments, whatever the task: divergence, noise, bad input, Lift's size variants (each task's fidelity
against robosuite's MuJoCo and its batch rollout: test_lift.py, test_pick_place_can.py, test_nut_assembly_square.py).

Only Lift's batched ``reset_to`` and ``step`` at batch 2 are compiled, the programs test_lift.py compiles too (JAX's
persistent cache shares them between the suite's processes). Everything runs in float32, the precision
`make sweep` uses.
"""

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

from poir_mjx.envs.env import batched, make_env, make_params
from poir_mjx.envs.tasks import UnknownTaskError

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
