"""SQIL learns the point-mass toy (tests/baselines/toy.py) from 16 expert demonstrations in 4000 environment steps.

Stated success: >= 0.8 of 32 evaluation episodes with the deterministic policy (the expert: 1.0; the untrained
policy: 0, which must stay below the bar). Seeds 0-3 all reached 1.0 at 3200 and 4000 steps when this was written.
The toy's temperature is fixed (alpha 0.01): with SAC's learned temperature SQIL reached 1.0 and then collapsed to 0
after about 5000 steps (alpha grew to 0.3, comparable with the 0/1 rewards); even fixed, runs much longer than this
one can collapse later (the policy rushes to unvisited x where the critic extrapolates upwards).
"""

import dataclasses

import jax
import numpy as np
import pytest

from poir_mjx.baselines.sac import SACConfig
from poir_mjx.baselines.sqil import PRESETS, SQIL, Config
from poir_mjx.core.config import ConfigError
from tests.baselines import toy

STEPS = 4000
CFG = Config(
    loop=toy.loop_config(STEPS, updates_per_iteration=8),  # one update per environment step
    sac=SACConfig(actor_width=64, critic_layers=2, critic_width=64, learning_rate=3e-4, learn_alpha=False,
                  init_alpha=0.01),  # fmt: skip
)


@pytest.fixture(scope="module")
def run():
    learner = SQIL(toy.ENV, CFG, 2, 2)
    state = learner.init(jax.random.PRNGKey(0), toy.expert_data(), toy.PARAMS)
    before = toy.success_rate(learner, state)
    iterations = STEPS // CFG.loop.num_envs
    state, m1 = learner.train(state, iterations // 2)  # two calls: the state carries everything across
    state, m2 = learner.train(state, iterations - iterations // 2)
    metrics = {k: np.concatenate([np.asarray(m1[k]), np.asarray(m2[k])]) for k in m1}
    return learner, state, metrics, before


def test_sqil_learns_the_toy(run):
    learner, state, metrics, before = run
    assert before < 0.8  # the control: without training the bar is not reached
    assert int(learner.env_steps(state)) == STEPS
    assert toy.success_rate(learner, state) >= 0.8
    # metrics: one entry per iteration; agent rewards are SQIL's 0; training episodes end every 15 steps
    assert metrics["imitation_reward"].shape == (STEPS // 8,) and np.all(metrics["imitation_reward"] == 0)
    ended = ~np.isnan(metrics["episode_success"])
    assert ended.sum() == STEPS // 8 // toy.HORIZON
    assert np.mean(metrics["episode_success"][ended][-5:]) > 0.5  # the stochastic policy succeeds too
    assert metrics["updating"][0] == 0 and metrics["updating"][-1] == 1  # warm-up, then updates
    assert np.isnan(metrics["critic_loss"][0]) and np.all(np.isfinite(metrics["critic_loss"][30:]))


def test_config_errors_name_the_field():
    for name in PRESETS:
        PRESETS[name].validate()
    with pytest.raises(ConfigError, match="expert_fraction"):
        dataclasses.replace(CFG, expert_fraction=1.0).validate()
    with pytest.raises(ConfigError, match="sac.discount"):
        dataclasses.replace(CFG, sac=dataclasses.replace(CFG.sac, discount=1.0)).validate()
    with pytest.raises(ConfigError, match="loop.num_envs"):
        dataclasses.replace(CFG, loop=dataclasses.replace(CFG.loop, num_envs=0)).validate()
    with pytest.raises(ConfigError, match="loop.replay_capacity"):
        dataclasses.replace(CFG, loop=dataclasses.replace(CFG.loop, replay_capacity=4)).validate()
    with pytest.raises(ConfigError, match="sac.learn_alpha: expected a boolean"):
        dataclasses.replace(CFG, sac=dataclasses.replace(CFG.sac, learn_alpha=1)).validate()


def test_training_resumes_from_a_saved_state():
    """train(s, 32) == train(restore(train(s, 16)), 16): the TrainState pytree is all a checkpoint needs."""
    learner = SQIL(toy.ENV, CFG, 2, 2)
    s0 = learner.init(jax.random.PRNGKey(1), toy.expert_data(), toy.PARAMS)
    whole, _ = learner.train(s0, 32)  # warm-up ends after iteration 30: the last two iterations update
    half, _ = learner.train(s0, 16)
    leaves, treedef = jax.tree_util.tree_flatten(half)
    resumed, _ = learner.train(jax.tree_util.tree_unflatten(treedef, [np.array(x) for x in leaves]), 16)
    assert int(resumed.env_steps) == 32 * 8
    names = [jax.tree_util.keystr(p) for p, _ in jax.tree_util.tree_flatten_with_path(whole)[0]]
    for name, a, b in zip(names, jax.tree_util.tree_leaves(whole), jax.tree_util.tree_leaves(resumed), strict=True):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-5, atol=1e-6, err_msg=name)
