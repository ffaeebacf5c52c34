"""bench l2: the full scan against the shortlist in the same planner calls. On a small trained L2 agent: the same
actions, the shortlist measuring a part of the expert states at states near the demos."""

import dataclasses

import jax
import numpy as np

from poir_mjx.bench.l2 import compare, to_markdown, with_shortlist
from poir_mjx.bench.options import BenchL2
from poir_mjx.core.agent import POIR
from tests.helpers import SMALL, expert_data


def test_both_searches_plan_the_same_actions_and_the_shortlist_measures_less():
    obs, act, nxt = expert_data()
    narrow = dataclasses.replace(SMALL.planner, sigma=0.05)  # candidates near the prior: imagined states lie together
    agent = POIR(dataclasses.replace(SMALL, planner=narrow), 2, 2)
    params, _ = agent.fit(jax.random.PRNGKey(0), obs, act, nxt)
    keys = np.asarray(jax.random.split(jax.random.PRNGKey(3), 6))
    groups = {"demo states": (obs[100:106], keys)}
    (row,) = compare(dataclasses.replace(BenchL2(), shortlist=128, calls=1), agent, params, groups)
    assert row["states"] == 6 and row["expert_states"] == params.expert_states.shape[0] > 128
    assert row["action_max_diff"] == 0.0
    assert row["shortlist_measured_mean"] <= 128 and row["steps_none_scanned"] > 0.0
    assert with_shortlist(agent, 0).config.planner.l2_shortlist == 0
    page = to_markdown({"run": "r", "task": "lift", "method": "POIR-L2", "seed": 0, "machine": "m", "simulator": "s",
                        "command": "c", "shortlist": 128, "calls": 1, "rows": [row]})  # fmt: skip
    assert "| demo states | 6 |" in page
