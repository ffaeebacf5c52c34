"""One planner call's record: the numbers the forensics report, from the probe's arrays (numpy in, JSON out)."""

from __future__ import annotations

import numpy as np

from poir_mjx.core.config import REWARDS
from poir_mjx.diagnose import call_stats as cs


def call_record(call: dict, k: int, n: int, top_k: int, true_returns: dict | None = None,
                true_first: np.ndarray | None = None) -> dict:  # fmt: skip
    """call: ``probe.call_fn``'s outputs as numpy; K heads, N real trajectories, the planner's top_k.
    true_returns: {reward: [N]} of the same candidates in the true simulator; true_first: [N, ds] the normalised
    states the true simulator reached after the first action (for the world model's one-step error)."""
    heads = cs.real_heads(k, n)
    rec: dict = {"plan_minus_ebc": _floats(call["plan"] - call["ebc"]),
                 "plan_ebc_distance": float(np.linalg.norm(call["plan"] - call["ebc"]))}  # fmt: skip
    for r in REWARDS:
        ret = cs.real_rows(call[f"returns_{r}"], n)
        top = cs.top_k_indices(ret, top_k)
        hist = cs.head_histogram(top, heads, k)
        rec[r] = {"top_k_heads": hist.tolist(), "one_head": bool(hist.max() == top_k),
                  "between_head_share": cs.between_head_share(ret, heads), "return_std": float(np.std(ret))}  # fmt: skip
        if true_returns is not None:
            tr = np.asarray(true_returns[r], np.float64)
            rec[r].update(spearman=cs.spearman(ret, tr), spearman_within_head=cs.within_head_spearman(ret, tr, heads),
                          top_k_overlap=cs.top_k_overlap(ret, tr, top_k),
                          true_between_head_share=cs.between_head_share(tr, heads),
                          true_return_std=float(np.std(tr)),
                          # how much better the model's top-k is than a random k, in true return
                          true_gain_model_top_k=float(tr[top].mean() - tr.mean()),
                          true_gain_oracle_top_k=float(tr[cs.top_k_indices(tr, top_k)].mean() - tr.mean()))  # fmt: skip
    rec["shares"] = shares(call, n)
    grip = cs.real_rows(call["first_env"], n)[:, -1]
    rec["gripper"] = {"ebc": float(call["ebc"][-1]),
                      "sign_differs_from_ebc": float(np.mean(np.sign(grip) != np.sign(call["ebc"][-1]))),
                      "at_bound": float(np.mean(np.abs(grip) >= 1.0))}  # fmt: skip
    if true_first is not None:
        pred = cs.real_rows(call["states"][1], n)
        rec["one_step_sq_error"] = _floats(np.mean((pred - true_first) ** 2, 0))
    return rec


def shares(call: dict, n: int) -> dict[str, list[float]]:
    """Each dimension's share of each reward over the call's real candidates and steps: L2 (observation
    dimensions, to the nearest expert state), DRIL (action dimensions, the most distant pair of BC heads),
    MOREL (observation dimensions, the most distant pair of world-model heads)."""
    def rows(x):  # [H, K, M, d] -> [H N, d]: every step of the real trajectories
        return np.concatenate([cs.real_rows(step, n) for step in np.asarray(x)])

    l2 = cs.dimension_shares(rows(call["scored"] - call["l2_near"]))
    dril = cs.dimension_shares(cs.max_pair_difference(np.stack([rows(h) for h in call["dril_heads"]])))
    morel = cs.dimension_shares(cs.max_pair_difference(np.stack([rows(h) for h in call["morel_heads"]])))
    return {"l2": _floats(l2), "dril": _floats(dril), "morel": _floats(morel)}


def _floats(x) -> list[float]:
    return [float(v) for v in np.asarray(x).ravel()]
