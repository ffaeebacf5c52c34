"""bench precision (issue 42): the planner's decisions under a reduced matmul against true float32, same states and
keys. On a small trained agent: float32 against itself agrees everywhere; bfloat16 moves the plan."""

import jax
import numpy as np

from poir_mjx.bench.precision import compare, to_markdown, with_matmul
from poir_mjx.core.agent import POIR
from tests.helpers import SMALL, expert_data


def test_decisions_are_compared_at_the_same_states_and_keys():
    obs, act, nxt = expert_data()
    agent = POIR(SMALL, 2, 2)
    params, _ = agent.fit(jax.random.PRNGKey(0), obs, act, nxt)
    keys = np.asarray(jax.random.split(jax.random.PRNGKey(3), 6))
    groups = {"demo states": (obs[:6] + 0.05, keys)}
    same, low = compare(agent, params, ("float32", "bfloat16"), groups)
    assert same["matmul"] == "float32" and same["top_k_same"] == 1.0 and same["plan_diff_max"] == 0.0
    assert low["states"] == 6 and low["plan_diff_max"] > 0.0 and low["ebc_diff_max"] > 0.0
    assert 0.0 <= low["top_k_shared_mean"] <= 1.0
    assert with_matmul(agent, "tf32").bc_module.matmul == "tf32" and agent.bc_module.matmul == "default"
    page = to_markdown({"run": "r", "task": "lift", "seed": 0, "machine": "m", "simulator": "s", "command": "c",
                        "demos": {"source": "file", "path": "d.hdf5", "sha256": "ab"}, "methods": {"POIR-L2": [low]}})  # fmt: skip
    assert "| POIR-L2 | demo states | bfloat16 | 6 |" in page and "d.hdf5" in page
