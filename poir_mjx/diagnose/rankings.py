"""Every ranking option of the planner applied to the same candidates of one call, so the oracle can say which of
them finds the candidates that are truly better, before any success-rate grid is run.

A ranking is a reward, a scoring and a selection (``PlannerConfig``: ``scoring``, ``selection``, ``dril_units``,
``l2_dims``); the candidates (prior, noise, world model, key) do not depend on any of them, so one call's candidates
are ranked by every option here and the true simulator's returns of those candidates (``diagnose/simulate.py``) say
what each option's chosen set gains over a random one. Proposal options (``gripper_noise``) change the candidates
and are measured by their grid only.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.cached import builder
from poir_mjx.core import candidates, selection as sel
from poir_mjx.core.agent import POIR
from poir_mjx.core.scoring import step_rewards
from poir_mjx.diagnose import call_stats as cs

NO_QUATERNIONS = "no_quaternions"  # l2_dims: every dimension but the quaternions' (core/ranking.quaternion_free)

# name -> (reward, planner fields, selection); every other ranking field at its default (the paper's planner)
RANKINGS: dict[str, tuple[str, dict, str]] = {
    "L2": ("l2", {}, "top_k"),
    "L2 head-centred": ("l2", {"scoring": "head_centred"}, "top_k"),
    "L2 head-balanced": ("l2", {}, "head_balanced"),
    "L2 all-models": ("l2", {"scoring": "all_models"}, "top_k"),
    "L2 no quaternions": ("l2", {"l2_dims": NO_QUATERNIONS}, "top_k"),
    "DRIL": ("dril", {}, "top_k"),
    "DRIL head-centred": ("dril", {"scoring": "head_centred"}, "top_k"),
    "DRIL head-balanced": ("dril", {}, "head_balanced"),
    "DRIL all-models": ("dril", {"scoring": "all_models"}, "top_k"),
    "DRIL action units": ("dril", {"dril_units": "action"}, "top_k"),
    "MOREL": ("morel", {}, "top_k"),
}
TRUTHS = ("l2", "dril")  # the true-simulator returns every ranking is judged by
_RESET = {"scoring": "own_model", "selection": "top_k", "dril_units": "normalized", "l2_dims": ()}


def ranking_agent(agent: POIR, name: str, no_quat: tuple[int, ...]) -> POIR:
    """The agent whose planner ranks as `name` does (its prior, models and candidates unchanged)."""
    reward, fields, _ = RANKINGS[name]
    fields = {k: (no_quat if v == NO_QUATERNIONS else v) for k, v in fields.items()}
    pc = dataclasses.replace(agent.config.planner, reward=reward, **{**_RESET, **fields})
    if pc.dril_units != "normalized" and pc.disagreement == "excess":
        pc = dataclasses.replace(pc, disagreement="raw")  # the config refuses the pair; the option is measured raw
    return POIR(dataclasses.replace(agent.config, planner=pc), agent.obs_size, agent.act_size)


@builder(maxsize=8)
def scores_fn(agent: POIR, no_quat: tuple[int, ...]):
    """jit((params, states [H + 1, K, M, ds], actions [H, K, M, da]) -> {name: [K, M]}): each ranking's score of
    the imagined candidates (``POIR.imagine``'s states and actions; -inf on padding)."""
    k, m = agent.head_layout()
    real = sel.real_mask(k, m, agent.config.planner.num_trajectories)
    variants = {name: ranking_agent(agent, name, no_quat) for name in RANKINGS}

    def fn(params, states, actions):
        out = {}
        for name, v in variants.items():
            pc = v.config.planner
            if pc.scoring == "all_models":
                ret = candidates.all_models_score(v, params, states[0], actions)
            else:
                ret = step_rewards(v, pc.reward, params, states, actions).sum(0)
            ret = jnp.where(real, ret, -jnp.inf)
            out[name] = sel.head_centred(ret, real) if pc.scoring == "head_centred" else ret
        return out

    return jax.jit(fn)


def chosen(name: str, ret: np.ndarray, k: int, top_k: int) -> np.ndarray:
    """Indices into the real trajectories' returns `ret` [N] (order n = k + K j) of those `name` averages: its
    top_k, or the best max(1, top_k // K) of every head (``selection.head_balanced_mean``)."""
    if RANKINGS[name][2] != "head_balanced":
        return cs.top_k_indices(ret, top_k)
    heads = cs.real_heads(k, len(ret))
    per_head = max(1, top_k // k)
    return np.concatenate([np.flatnonzero(heads == h)[cs.top_k_indices(ret[heads == h], per_head)] for h in range(k)])


def ranking_records(scores: dict, true_returns: dict, k: int, top_k: int) -> dict:
    """{name: {truth: {spearman, gain}}}: each ranking ([K, M] scores) against each true return ([N]) of the same
    candidates; gain: the true return of its chosen set above the candidates' mean (random selection's expectation
    is 0)."""
    n = len(true_returns[TRUTHS[0]])
    out = {}
    for name, s in scores.items():
        ret = cs.real_rows(s, n)
        pick = chosen(name, ret, k, top_k)
        out[name] = {}
        for t in TRUTHS:
            tr = np.asarray(true_returns[t], np.float64)
            out[name][t] = {"spearman": cs.spearman(ret, tr), "gain": float(tr[pick].mean() - tr.mean())}
    return out


def summarize(episodes: list[list[dict]]) -> dict:
    """{truth: {name: {spearman, gain, gain_se, episodes_ahead}, "oracle": {gain}}} over a cell's planner calls
    (`episodes`: each episode's calls): the mean Spearman and true gain of each ranking over calls, the gain's
    standard error clustered by episode (calls of one episode are not independent) and the episodes whose mean gain
    is above 0; "oracle": what the true top-k gains (the most any ranking of these candidates could)."""
    out: dict = {}
    for t in TRUTHS:
        out[t] = {}
        for name in RANKINGS:
            gains = [np.array([c["rankings"][name][t]["gain"] for c in calls], np.float64) for calls in episodes]
            rho = np.array([c["rankings"][name][t]["spearman"] for calls in episodes for c in calls], np.float64)
            out[t][name] = {"spearman": float(np.nanmean(rho)) if np.isfinite(rho).any() else float("nan"),
                            "gain": float(np.concatenate(gains).mean()), "gain_se": clustered_se(gains),
                            "episodes_ahead": sum(int(g.mean() > 0) for g in gains), "episodes": len(gains)}  # fmt: skip
        out[t]["oracle"] = {"gain": float(np.mean([c[t]["true_gain_oracle_top_k"] for calls in episodes for c in calls]))}
    return out


def clustered_se(groups: list[np.ndarray]) -> float:
    """The standard error of the mean of all values, clustered by group (CR1: sqrt(G / (G - 1) * sum_g (sum of
    group g's deviations from the overall mean)^2) / n); NaN with fewer than two groups."""
    groups = [np.asarray(g, np.float64) for g in groups if len(g)]
    if len(groups) < 2:
        return float("nan")
    n, mean = sum(len(g) for g in groups), np.concatenate(groups).mean()
    return float(np.sqrt(len(groups) / (len(groups) - 1) * sum(np.sum(g - mean) ** 2 for g in groups)) / n)


def render(summary: dict) -> list[str]:
    """The page's section (markdown lines) for cells whose records have rankings."""
    cells = {c: s["rankings"] for c, s in summary.items() if "rankings" in s}
    if not cells:
        return []
    lines = ["", "## Every ranking option on the same candidates", "",
             "Each option of the planner's ranking (reward, `scoring`, `selection`, `dril_units`, `l2_dims`) ranks the "
             "same candidates of every call; cell: the true return its chosen set gains over the candidates' mean "
             "(a random choice gains 0 on average) ± its standard error clustered by episode, the episodes whose mean "
             "gain is above 0, then Spearman with the true returns. Above zero by 2 standard errors in most episodes: "
             "the option's ranking finds truly better candidates.", ""]  # fmt: skip
    for t in TRUTHS:
        rows = [[name, *[_cell(s[t][name]) for s in cells.values()]] for name in RANKINGS]
        rows.append(["the true top-k (oracle)", *[f"{s[t]['oracle']['gain']:+.3g}" for s in cells.values()]])
        lines += [f"**Judged by the true {t.upper()} return**", "",
                  "| ranking | " + " | ".join(cells) + " |", "|" + "---|" * (len(cells) + 1),
                  *["| " + " | ".join(r) + " |" for r in rows], ""]  # fmt: skip
    return lines


def _cell(x: dict) -> str:
    return f"{x['gain']:+.3g} ± {x['gain_se']:.2g}, {x['episodes_ahead']}/{x['episodes']} ({x['spearman']:+.2f})"
