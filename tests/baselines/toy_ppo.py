"""The PPO+DRIL toy: the point mass of tests/helpers.py with a y drift the expert never saw.

The expert (recorded without drift) moves +x at 0.05 per step and pulls y back towards 0 (a_y = -0.5 y), so its states
lie in a thin band |y| < ~0.04 and it reaches x = 1 (success, if |y| < 0.05) at step 20. In deployment a drift of
``DRIFT`` per step pushes y up: behaviour cloning settles at y = 2 x DRIFT = 0.08 and never succeeds; a policy that
also cancels the drift (a_y = -0.5 y - DRIFT) stays in the band, which is what DRIL's reward asks for.
"""

import dataclasses

import jax.numpy as jnp
import numpy as np

from poir_mjx.baselines.learner import ExpertData
from poir_mjx.envs.env import make_params
from tests.helpers import PointMassEnv

DRIFT = 0.04
HORIZON = 30


@dataclasses.dataclass(frozen=True)
class TimedPointMass(PointMassEnv):
    """The point mass observing (x, y, t / horizon): with the time in view, standing still leaves the expert's
    support as surely as drifting does (the expert is at x = 0.05 t)."""

    def obs_vector(self, state):
        return jnp.concatenate([state.obs["s"], (state.info["step"] / self.horizon)[None].astype(state.obs["s"].dtype)])


ENV = TimedPointMass(drift_y=DRIFT, horizon=HORIZON)
DEPLOY = make_params(sigma_init=0.02, sigma_action=0.0)


def expert_action(s, rng):
    return np.array([0.05, -0.5 * s[1]]) + rng.normal(0.0, [0.005, 0.01])


def expert_data(n_demos=40, steps=HORIZON, seed=0) -> ExpertData:
    """Demonstrations in the drift-free environment (s' = s + a), y_0 ~ N(0, 0.02)."""
    rng = np.random.default_rng(seed)
    obs, act, nxt, term, init = [], [], [], [], []
    for _ in range(n_demos):
        s = np.array([0.0, rng.normal(0.0, 0.02)])
        for t in range(steps):
            a = expert_action(s, rng)
            obs.append([*s, t / HORIZON]), act.append(a), nxt.append([*(s + a), (t + 1) / HORIZON])
            term.append(t == steps - 1), init.append(t == 0)
            s = s + a
    f = lambda x: np.array(x, np.float32)  # noqa: E731
    return ExpertData(f(obs), f(act), f(nxt), np.array(term), np.array(init))
