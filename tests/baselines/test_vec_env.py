"""Vectorised environments with auto-reset (poir_mjx/baselines/vec_env.py) on the point-mass toy."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx.baselines import vec_env
from poir_mjx.envs.env import make_params
from tests.helpers import PointMassEnv


def _run(vec, steps, action, key=0):
    vs = vec.reset(jax.random.PRNGKey(key), make_params(0.1, 0.0))
    step, out = jax.jit(vec.step), []
    for i in range(steps):
        vs, tr = step(vs, jnp.broadcast_to(jnp.asarray(action, jnp.float32), (vec.num_envs, 2)), jax.random.PRNGKey(i))
        out.append(tr)
    return vs, out


def test_episodes_are_truncated_and_reset():
    vec = vec_env.VecEnv(PointMassEnv(drift_y=0.0, horizon=30), num_envs=3, episode_steps=4)
    vs0 = vec.reset(jax.random.PRNGKey(0), make_params(0.1, 0.0))
    assert len(set(np.round(np.asarray(vs0.obs[:, 1]), 6))) == 3  # one reset key per environment
    vs, trs = _run(vec, 9, [0.3, 0.0])
    ends = np.array([np.asarray(t.end) for t in trs])
    np.testing.assert_array_equal(ends.all(1), [False, False, False, True, False, False, False, True, False])
    # the transition keeps the episode's last observation; the state restarts at x = 0
    np.testing.assert_allclose(trs[3].next_obs[:, 0], 1.2, rtol=1e-6)
    np.testing.assert_allclose(trs[4].obs[:, 0], 0.0)
    assert np.all(np.asarray(trs[3].success) == (np.abs(np.asarray(trs[3].next_obs[:, 1])) < 0.05))
    assert int(vs.env.info["step"][0]) == 1
    # fresh episodes draw new starts
    assert not np.allclose(trs[0].obs[:, 1], trs[4].obs[:, 1])
    assert np.isnan(vec_env.episode_success(trs[0]))
    assert float(vec_env.episode_success(trs[3])) == pytest.approx(float(np.mean(np.asarray(trs[3].success))))


def test_environment_done_ends_the_episode():
    vec = vec_env.VecEnv(PointMassEnv(horizon=2), num_envs=2, episode_steps=10)
    _, trs = _run(vec, 3, [0.0, 0.0])
    assert [bool(t.end.all()) for t in trs] == [False, True, False]


@dataclasses.dataclass(frozen=True)
class Exploding(PointMassEnv):
    """Diverges (NaN state, diverged flag) once x passes 0.5."""

    def step(self, state, action):
        nxt = super().step(state, action)
        bad = nxt.data[0] > 0.5
        s = jnp.where(bad, jnp.nan, nxt.data)
        return nxt.replace(data=s, obs={"s": s}, done=nxt.done | bad, info=dict(nxt.info, diverged=bad))


def test_diverged_steps_are_invalid_and_end_the_episode():
    vec = vec_env.VecEnv(Exploding(), num_envs=2, episode_steps=10)
    _, trs = _run(vec, 3, [0.3, 0.0])
    assert [bool(t.valid.all()) for t in trs] == [True, False, True]
    assert bool(trs[1].end.all()) and np.all(np.isfinite(np.asarray(trs[1].next_obs)))
    np.testing.assert_allclose(trs[2].obs[:, 0], 0.0)  # restarted


def test_bad_sizes_name_the_field():
    with pytest.raises(ValueError, match="num_envs"):
        vec_env.VecEnv(PointMassEnv(), num_envs=0, episode_steps=4)
    with pytest.raises(ValueError, match="episode_steps"):
        vec_env.VecEnv(PointMassEnv(), num_envs=1, episode_steps=0)
