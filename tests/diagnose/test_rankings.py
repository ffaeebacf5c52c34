"""Every ranking option on the same candidates: each score is what a planner with that option returns for the same
key, each chosen set is what that planner averages, and the judgement against true returns is exact."""

import dataclasses

import jax
import numpy as np
import pytest

from poir_mjx.core.agent import POIR
from poir_mjx.diagnose import call_stats as cs, probe, rankings
from tests.helpers import SMALL, expert_data

NO_QUAT = (0, 1)  # the point mass has no quaternion


@pytest.fixture(scope="module")
def trained():
    obs, act, nxt = expert_data()
    agent = POIR(dataclasses.replace(SMALL, planner=dataclasses.replace(SMALL.planner, num_trajectories=62)), 2, 2)
    params, _ = agent.fit(jax.random.PRNGKey(0), obs, act, nxt)
    return agent, params, obs


def _scores(agent, params, obs, key):
    imag = agent.imagine(params, obs, key)
    return jax.tree_util.tree_map(np.asarray, rankings.scores_fn(agent, NO_QUAT)(params, imag.states, imag.actions))


@pytest.mark.parametrize("name", ["L2", "L2 head-centred", "L2 all-models", "DRIL", "DRIL head-centred",
                                  "DRIL all-models", "DRIL action units", "MOREL"])  # fmt: skip
def test_each_score_is_the_options_own_planner_returns(trained, name):
    agent, params, obs = trained
    key = jax.random.PRNGKey(11)
    scores = _scores(agent, params, obs[6], key)
    ret, _ = rankings.ranking_agent(agent, name, NO_QUAT).rollouts(params, obs[6], key)
    np.testing.assert_allclose(scores[name], ret, rtol=1e-5, atol=1e-6)


def test_the_options_differ_from_the_paper_ranking(trained):
    """A sanity check that the variants are not the base ranking under another name."""
    agent, params, obs = trained
    s = _scores(agent, params, obs[6], jax.random.PRNGKey(11))
    for a, b in (("DRIL", "DRIL head-centred"), ("DRIL", "DRIL all-models"), ("DRIL", "DRIL action units"),
                 ("L2", "L2 all-models")):  # fmt: skip
        real = np.isfinite(s[a])
        assert not np.allclose(s[a][real], s[b][real])


@pytest.mark.parametrize("name", ["DRIL", "DRIL head-balanced"])
def test_the_chosen_set_is_what_the_planner_averages(trained, name):
    agent, params, obs = trained
    key = jax.random.PRNGKey(12)
    s = _scores(agent, params, obs[3], key)
    v = rankings.ranking_agent(agent, name, NO_QUAT)
    if rankings.RANKINGS[name][2] == "head_balanced":
        v = POIR(dataclasses.replace(v.config, planner=dataclasses.replace(v.config.planner, selection="head_balanced")),
                 2, 2)  # fmt: skip
    ret, first = v.rollouts(params, obs[3], key)
    k, _ = agent.head_layout()
    pick = rankings.chosen(name, cs.real_rows(s[name], 62), k, agent.config.planner.top_k)
    firsts = cs.real_rows(np.asarray(first), agent.config.planner.num_trajectories)
    np.testing.assert_allclose(firsts[pick].mean(0), v.select(ret, first, key), rtol=1e-5, atol=1e-6)
    if name == "DRIL head-balanced":  # top_k 4 over K heads: the best of each head
        assert sorted(cs.real_heads(k, 62)[pick].tolist()) == sorted(range(k)) * max(1, 4 // k)


def test_judged_by_its_own_scores_a_ranking_gains_what_the_oracle_gains():
    rng = np.random.default_rng(0)
    s = rng.normal(size=(3, 4))
    true = {"l2": cs.real_rows(s, 12), "dril": -cs.real_rows(s, 12)}
    rec = rankings.ranking_records({"L2": s}, true, 3, 2)["L2"]
    best = np.sort(true["l2"])[-2:].mean() - true["l2"].mean()
    assert rec["l2"]["spearman"] == pytest.approx(1) and rec["l2"]["gain"] == pytest.approx(best)
    assert rec["dril"]["spearman"] == pytest.approx(-1) and rec["dril"]["gain"] < 0


def test_the_gains_error_is_clustered_by_episode():
    """Two episodes of constant gains 1 and 3: the clustered error is that of the two episode means (1), not the
    much smaller one of four independent calls."""
    assert rankings.clustered_se([np.array([1.0, 1.0]), np.array([3.0, 3.0])]) == pytest.approx(1.0)
    assert np.isnan(rankings.clustered_se([np.array([1.0, 2.0])]))
    calls = [{"rankings": {n: {t: {"gain": g, "spearman": 0.5} for t in rankings.TRUTHS} for n in rankings.RANKINGS},
              **{t: {"true_gain_oracle_top_k": 4.0} for t in rankings.TRUTHS}} for g in (2.0, 2.0, -1.0, -1.0)]  # fmt: skip
    s = rankings.summarize([calls[:2], calls[2:]])["l2"]
    assert s["L2"]["gain"] == pytest.approx(0.5) and s["L2"]["episodes_ahead"] == 1 and s["oracle"]["gain"] == 4.0
