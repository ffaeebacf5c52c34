"""Online fine-tuning on the toy point mass with a known mismatch (a y drift the demos never had)."""

import dataclasses

import jax
import numpy as np
import pytest

from poir_mjx.core.agent import POIR
from poir_mjx.core.checkpoint import CheckpointError
from poir_mjx.core.config import OnlineConfig
from poir_mjx.envs.env import make_params
from poir_mjx.rollout.sharding import run_sharded
from poir_mjx.online.finetune import deployment_error
from poir_mjx.online.loop import OnlineTrainer
from tests.helpers import SMALL
from tests.helpers import expert_data
from tests.helpers import PointMassEnv

CFG = dataclasses.replace(
    SMALL,  # the planner tests' toy agent (L2 reward)
    # 4 rounds of 8 episodes x 30 steps; the toy's short run mixes faster than the paper's 100 steps.
    online=OnlineConfig(total_env_steps=960, num_envs=8, eval_every=480, buffer_capacity=2000, mix_every=10),
)
ENV = PointMassEnv(drift_y=0.01)
DEPLOY = make_params(0.05, 0.0)


@pytest.fixture(scope="module")
def setup():
    obs, act, nxt = expert_data()
    agent = POIR(CFG, 2, 2)
    params, _ = agent.fit(jax.random.PRNGKey(0), obs, act, nxt)
    trainer = OnlineTrainer(ENV, agent, 30)
    eval_keys = jax.random.split(jax.random.PRNGKey(5), 48)
    result = trainer.run(params, (obs, act, nxt), DEPLOY, eval_keys, jax.random.PRNGKey(1))
    return trainer, params, (obs, act, nxt), eval_keys, result


def test_world_model_error_on_deployment_data_drops(setup):
    trainer, params, _, _, result = setup
    # fresh deployment transitions (keys never used in the run), collected by the fine-tuned agent
    _, (o, a, o2, v) = run_sharded(trainer.collector, result.params, jax.random.split(jax.random.PRNGKey(99), 16),
                                   jax.tree_util.tree_map(lambda x: np.full(16, x), DEPLOY))  # fmt: skip
    flat = [x.reshape((-1,) + x.shape[2:]) for x in (o, a, o2, v)]
    module = trainer.agent.wm_module
    before = np.asarray(deployment_error(module, params.wm, params.obs_norm, params.act_norm, *flat))
    after = np.asarray(deployment_error(module, result.params.wm, params.obs_norm, params.act_norm, *flat))
    assert np.all(after < 0.2 * before), (before, after)
    # the per-round record says the same on each round's held-out data
    assert result.rounds[-1]["wm_error"] < 0.2 * result.rounds[-1]["wm_error_offline"]
    assert result.rounds[0]["wm_error"] == pytest.approx(result.rounds[0]["wm_error_offline"])
    # the BC prior and the MOREL reward's world model are the offline ones
    for name in ("bc", "reward_wm"):
        for x, y in zip(jax.tree_util.tree_leaves(getattr(params, name)), jax.tree_util.tree_leaves(getattr(result.params, name))):
            np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def test_success_is_not_reduced(setup):
    _, _, _, _, result = setup
    assert [c["env_steps"] for c in result.curve] == [0, 480, 960]
    offline, online = result.curve[0]["successes"], result.curve[-1]["successes"]
    assert online >= offline, result.curve
    assert result.rounds[-1]["online_fraction"] == pytest.approx(0.5)


def test_interrupted_run_resumes_to_the_same_result(setup, tmp_path):
    trainer, params, offline, eval_keys, result = setup
    ckpt = tmp_path / "online.ckpt"

    class Stop(Exception):
        pass

    def stop_after_second(r, log):
        if r == 1:
            raise Stop

    with pytest.raises(Stop):
        trainer.run(params, offline, DEPLOY, eval_keys, jax.random.PRNGKey(1), checkpoint_path=ckpt,
                    config_hash="h", on_round=stop_after_second)  # fmt: skip
    resumed = trainer.run(params, offline, DEPLOY, eval_keys, jax.random.PRNGKey(1), checkpoint_path=ckpt, config_hash="h")
    assert resumed.resumed_from_round == 2
    assert [c["successes"] for c in resumed.curve] == [c["successes"] for c in result.curve]
    assert [r["wm_error"] for r in resumed.rounds] == pytest.approx([r["wm_error"] for r in result.rounds], rel=1e-6)
    for x, y in zip(jax.tree_util.tree_leaves(result.params.wm), jax.tree_util.tree_leaves(resumed.params.wm)):
        np.testing.assert_allclose(np.asarray(x), np.asarray(y), rtol=1e-6, atol=1e-7)
    # a finished run restarts as a no-op; another config's hash is refused with the file and field named
    again = trainer.run(params, offline, DEPLOY, eval_keys, jax.random.PRNGKey(1), checkpoint_path=ckpt, config_hash="h")
    assert again.resumed_from_round == 4 and again.curve == resumed.curve
    with pytest.raises(CheckpointError, match="online.ckpt: field 'config_hash'"):
        trainer.run(params, offline, DEPLOY, eval_keys, jax.random.PRNGKey(1), checkpoint_path=ckpt, config_hash="other")


def test_a_fine_tuning_whose_loss_diverges_stops_with_one_line(setup, monkeypatch, tmp_path):
    import jax.numpy as jnp

    from poir_mjx.core.agent import TrainingDivergedError
    from poir_mjx.online import loop

    trainer, params, offline, eval_keys, _ = setup
    real = loop.finetune

    def diverging(*args, **kwargs):
        wm, losses, frac = real(*args, **kwargs)
        return wm, jnp.full_like(losses, jnp.inf), frac

    monkeypatch.setattr(loop, "finetune", diverging)
    with pytest.raises(TrainingDivergedError, match=r"online fine-tuning, round 1: the training loss 'loss' is not "
                                                    r"finite"):
        trainer.run(params, offline, DEPLOY, eval_keys, jax.random.PRNGKey(1), checkpoint_path=tmp_path / "o.ckpt",
                    config_hash="h")  # fmt: skip
