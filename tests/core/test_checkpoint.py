import dataclasses
import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx import checkpoint_codec as codec
from poir_mjx.core import checkpoint
from poir_mjx.core.agent import POIR
from poir_mjx.core.config import MLPConfig, PlannerConfig, POIRConfig, TrainConfig
from tests.helpers import expert_data

CFG = POIRConfig(
    ensemble_size=2,
    bc=MLPConfig(layers=2, width=8),
    world_model=MLPConfig(layers=2, width=8),
    train=TrainConfig(epochs=2, batch_size=32),
    planner=PlannerConfig(num_trajectories=5, horizon=2, top_k=2, reward="morel"),
)
LAYOUT = {"task": "toy", "obs_keys": ["s"]}


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    obs, act, nxt = expert_data(n_demos=4, steps=10)
    agent = POIR(CFG, 2, 2)
    params, _ = agent.fit(jax.random.PRNGKey(0), obs, act, nxt)
    path = checkpoint.save(tmp_path_factory.mktemp("ck") / "agent.ckpt", agent, params, LAYOUT)
    return agent, params, path


def test_round_trip_gives_identical_actions(saved):
    agent, params, path = saved
    agent2, params2, layout = checkpoint.load(path, CFG, LAYOUT)
    assert agent2.config == CFG and layout["obs_size"] == 2
    s = jnp.array([0.1, 0.2])
    np.testing.assert_array_equal(agent.plan(params, s, jax.random.PRNGKey(3)), agent2.plan(params2, s, jax.random.PRNGKey(3)))
    np.testing.assert_array_equal(agent.ebc_action(params, s), agent2.ebc_action(params2, s))
    assert not list(path.parent.glob(".*.tmp"))  # no temporary file left behind


def test_mismatched_config_names_the_field(saved):
    _, _, path = saved
    other = dataclasses.replace(CFG, planner=dataclasses.replace(CFG.planner, horizon=3))
    with pytest.raises(checkpoint.CheckpointError, match=r"agent\.ckpt: config field 'planner\.horizon'"):
        checkpoint.load(path, other)


def test_mismatched_layout_names_the_field(saved):
    _, _, path = saved
    with pytest.raises(checkpoint.CheckpointError, match="layout field 'task'"):
        checkpoint.load(path, CFG, {"task": "lift"})


def test_parameters_are_checked_by_name_and_shape(saved, tmp_path):
    _, _, path = saved
    blob = codec.read(path, checkpoint.FORMAT)
    kernel = blob["params"]["bc"]["params"]["Dense_0"]["kernel"]
    blob["params"]["bc"]["params"]["Dense_0"]["kernel"] = kernel[:, :1]
    bad = codec.write(tmp_path / "narrow.ckpt", checkpoint.FORMAT, {k: v for k, v in blob.items() if k != "format"})
    with pytest.raises(checkpoint.CheckpointError,
                       match=rf"narrow\.ckpt: field 'params\.bc\.params\.Dense_0\.kernel' has shape \(2, 1, 8\), "
                             rf"expected {re.escape(str(kernel.shape))}"):  # fmt: skip
        checkpoint.load(bad)
    blob["params"]["bc"]["params"]["Dense_0"]["kernel"] = kernel
    del blob["params"]["obs_norm"]["std"]
    bad = codec.write(tmp_path / "nostd.ckpt", checkpoint.FORMAT, {k: v for k, v in blob.items() if k != "format"})
    with pytest.raises(checkpoint.CheckpointError, match=r"nostd\.ckpt: field 'params\.obs_norm\.std' is missing"):
        checkpoint.load(bad)


def test_garbage_file_is_a_clear_error(tmp_path):
    bad = tmp_path / "bad.ckpt"
    bad.write_bytes(b"not msgpack at all")
    with pytest.raises(checkpoint.CheckpointError, match="bad.ckpt"):
        checkpoint.load(bad)
    with pytest.raises(checkpoint.CheckpointError, match="no such checkpoint"):
        checkpoint.load(tmp_path / "missing.ckpt")
