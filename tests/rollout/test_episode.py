"""The one episode rollout (poir_mjx/rollout/episode.py) on the point-mass toy, which implements the env protocol."""

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.envs.env import make_params
from poir_mjx.rollout.episode import Policy, batched_episodes, run_episode, stateless
from poir_mjx.rollout.protocol import INFO_KEYS, Env
from tests.helpers import PointMassEnv


def test_toy_env_implements_the_protocol():
    env = PointMassEnv()
    assert isinstance(env, Env)
    state = env.reset(jax.random.PRNGKey(0), make_params(0.1, 0.0))
    assert set(INFO_KEYS) <= set(state.info)


def test_outcomes_and_records_follow_the_episode():
    env = PointMassEnv(drift_y=0.0, horizon=30)
    go_right = stateless(env, lambda params, obs, key: jnp.array([params, -obs[1]]))
    record = lambda s, a, s2: (env.obs_vector(s), a, env.obs_vector(s2))  # noqa: E731
    episodes = batched_episodes(env, go_right, 12, record)
    keys = jax.random.split(jax.random.PRNGKey(1), 3)
    out, (o, a, o2) = episodes(jnp.float32(0.25), keys, make_params(np.zeros(3), 0.0))
    # x grows 0.25 a step from 0: x >= 1 first at step 4, with y corrected to 0 at step 1
    np.testing.assert_array_equal(out["first_success"], [4, 4, 4])
    np.testing.assert_array_equal(out["steps"], [12, 12, 12])
    assert o.shape == (3, 12, 2) and a.shape == (3, 12, 2)
    np.testing.assert_allclose(o2[:, :-1], o[:, 1:])  # each step starts where the previous one ended
    np.testing.assert_allclose(o2[:, -1, 0], 3.0, rtol=1e-6)


def test_carry_is_seeded_by_the_run_key_and_each_step_gets_its_own_key():
    env = PointMassEnv()
    key = jax.random.PRNGKey(3)
    _, k_run = jax.random.split(key)
    # the carry counts steps from the run key's first bits; the action reveals the step key
    policy = Policy(act=lambda p, c, s, k: (jax.random.uniform(k, (2,)) * 0.01, c + 1),
                    init=lambda p, k: jax.random.bits(k, dtype=jnp.uint32) % 7)  # fmt: skip
    state, actions = run_episode(env, policy, None, key, make_params(0.0, 0.0), 4, record=lambda s, a, s2: a)
    expected = jax.vmap(lambda k: jax.random.uniform(k, (2,)) * 0.01)(jax.random.split(k_run, 4))
    np.testing.assert_allclose(actions, expected)
    assert len({tuple(np.asarray(a)) for a in actions}) == 4
    assert int(state.info["step"]) == 4
