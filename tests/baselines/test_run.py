"""The baseline run loop (poir_mjx/baselines/run.py) with a learner whose progress is known in advance."""

import dataclasses

import jax
import numpy as np

from poir_mjx.baselines.learner import ExpertData
from poir_mjx.baselines.run import chunk_iterations, expert_data, train_baseline
from poir_mjx.envs.env import make_params
from tests.helpers import StepLearner
from tests.helpers import PointMassEnv

ENV = PointMassEnv(drift_y=0.0, horizon=30)


def _run(path, total):
    keys = jax.random.split(jax.random.PRNGKey(0), 8)
    return train_baseline(StepLearner(), ENV, None, make_params(0.05, 0.0), keys, 30, jax.random.PRNGKey(1),
                          total_env_steps=total, eval_every=8, env_steps_per_iteration=4, checkpoint_path=path)  # fmt: skip


def test_curve_follows_training_and_resumes_identically(tmp_path):
    assert chunk_iterations(4, 8) == 2 and chunk_iterations(16, 8) == 1
    full = _run(tmp_path / "a.ckpt", 24)
    steps = [c["env_steps"] for c in full.curve]
    assert steps == [0, 8, 16, 24]
    rates = [c["success_rate"] for c in full.curve]
    assert rates[0] == 0.0 and rates[-1] == 1.0  # speed 0 never reaches x = 1; speed 0.06 does within 30 steps
    half = _run(tmp_path / "b.ckpt", 8)
    assert half.resumed_from_env_steps == 0
    rest = _run(tmp_path / "b.ckpt", 24)
    assert rest.resumed_from_env_steps == 8
    strip = lambda c: [{k: v for k, v in e.items() if k != "wall_s"} for e in c]  # noqa: E731
    assert strip(rest.curve) == strip(full.curve)


def test_expert_data_marks_demo_starts_and_ends():
    @dataclasses.dataclass
    class Tr:
        obs = np.zeros((5, 2))
        actions = np.zeros((5, 2))
        next_obs = np.zeros((5, 2))
        demo_starts = np.array([0, 3])
        demo_lengths = np.array([3, 2])

    ex = expert_data(Tr())
    assert isinstance(ex, ExpertData) and ex.obs.dtype == np.float32
    np.testing.assert_array_equal(ex.initial, [1, 0, 0, 1, 0])
    np.testing.assert_array_equal(ex.terminal, [0, 0, 1, 0, 1])


def test_a_baseline_whose_loss_diverges_stops_with_one_line(tmp_path):
    import jax.numpy as jnp
    import pytest

    from poir_mjx.core.agent import TrainingDivergedError

    @dataclasses.dataclass(frozen=True)
    class Diverging(StepLearner):
        def train(self, state, iterations):
            state, metrics = super().train(state, iterations)
            return state, {**metrics, "critic_loss": jnp.full(iterations, jnp.nan)}

    keys = jax.random.split(jax.random.PRNGKey(0), 2)
    with pytest.raises(TrainingDivergedError, match=r"step-learner at 8 environment steps: the training loss "
                                                    r"'critic_loss' is not finite"):
        train_baseline(Diverging(), ENV, None, make_params(0.05, 0.0), keys, 30, jax.random.PRNGKey(1),
                       total_env_steps=24, eval_every=8, env_steps_per_iteration=4,
                       checkpoint_path=tmp_path / "c.ckpt")  # fmt: skip
