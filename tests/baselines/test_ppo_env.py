"""PPO's vectorised environments: auto-reset at episode_steps, diverged physics, success of ended episodes."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.baselines import ppo_env
from tests.baselines.toy_ppo import DEPLOY, TimedPointMass


@dataclasses.dataclass(frozen=True)
class Diverging(TimedPointMass):
    """Goes non-finite at step 2 when the x action exceeds 0.4."""

    def step(self, state, action):
        nxt = super().step(state, action)
        s = jnp.where((nxt.info["step"] == 2) & (action[0] > 0.4), jnp.nan, nxt.data)
        return nxt.replace(data=s, obs={"s": s})


def test_auto_reset_divergence_and_success():
    env = Diverging(drift_y=0.0, horizon=30)
    params = ppo_env.broadcast_params(DEPLOY, 3)
    # env 0 diverges at step 2; env 1 reaches x = 1.05 (success) and is truncated at episode_steps = 3; env 2 neither
    actions = jnp.array([[0.45, 0.0], [0.35, 0.0], [0.1, 0.0]])

    @jax.jit
    def run(key):
        states = ppo_env.reset(env, key, params)
        outs = []
        for t in range(3):
            states, out = ppo_env.step(env, 3, states, params, actions, jax.random.fold_in(key, t))
            outs.append(out)
        return states, jax.tree_util.tree_map(lambda *x: jnp.stack(x), *outs)

    states, out = jax.tree_util.tree_map(np.asarray, run(jax.random.PRNGKey(0)))
    np.testing.assert_array_equal(out.ended, [[False] * 3, [True, False, False], [False, True, True]])
    np.testing.assert_array_equal(out.diverged[:, 0], [False, True, False])
    assert not out.diverged[:, 1:].any()
    assert np.isnan(out.next_obs[1, 0, :2]).all()  # the diverged state as it was, before the reset
    assert out.next_obs[2, 1, 0] > 1.0 and abs(out.next_obs[2, 1, 2] - 3 / 30) < 1e-6  # env 1 before its reset
    np.testing.assert_array_equal(out.success, [[False] * 3, [False] * 3, [False, True, False]])
    # after the resets: env 0 restarted at step 1 and took one step; envs 1, 2 restarted at step 0
    np.testing.assert_array_equal(states.info["step"], [1, 0, 0])
    assert np.isfinite(states.data).all()
