"""What one planner call did, from its imagined trajectories: pure functions of arrays (no simulator).

Layout: trajectory n = k + K j of the [K, M] head layout keeps head k (``POIR.head_layout``); "real" trajectories are
n < N (the padding cells are dropped).
"""

from __future__ import annotations

import numpy as np


def real_heads(k: int, n: int) -> np.ndarray:
    """Head of each real trajectory n = 0..N-1 (n mod K)."""
    return np.arange(n) % k


def real_rows(x: np.ndarray, n: int) -> np.ndarray:
    """[K, M, ...] -> [N, ...] in the order n = k + K j (the planner's ``real_trajectories``)."""
    x = np.asarray(x)
    return np.swapaxes(x, 0, 1).reshape(-1, *x.shape[2:])[:n]


def top_k_indices(returns: np.ndarray, k: int) -> np.ndarray:
    """Indices of the k largest returns (NaN last, ties by index, as ``lax.top_k``)."""
    r = np.where(np.isnan(returns), -np.inf, returns)
    return np.argsort(-r, kind="stable")[:k]


def head_histogram(top: np.ndarray, heads: np.ndarray, k: int) -> np.ndarray:
    """How many of the chosen trajectories each head supplied, [K]."""
    return np.bincount(heads[top], minlength=k)


def between_head_share(returns: np.ndarray, heads: np.ndarray) -> float:
    """The share of the returns' variance explained by which head a trajectory used (one-way ANOVA's R^2):
    sum_k n_k (mean_k - mean)^2 / sum_n (r_n - mean)^2; 0 when the returns do not vary."""
    r = np.asarray(returns, np.float64)
    total = np.sum((r - r.mean()) ** 2)
    if not total > 0:
        return 0.0
    between = sum(np.sum(heads == h) * (r[heads == h].mean() - r.mean()) ** 2 for h in np.unique(heads))
    return float(between / total)


def spearman(x: np.ndarray, y: np.ndarray) -> float:
    """Spearman's rank correlation (average ranks for ties); NaN when either side is constant."""
    from scipy.stats import rankdata

    rx, ry = rankdata(np.asarray(x, np.float64)), rankdata(np.asarray(y, np.float64))
    rx, ry = rx - rx.mean(), ry - ry.mean()
    den = np.sqrt(np.sum(rx**2) * np.sum(ry**2))
    return float(np.sum(rx * ry) / den) if den > 0 else float("nan")


def within_head_spearman(x: np.ndarray, y: np.ndarray, heads: np.ndarray) -> float:
    """The mean over heads of Spearman between x and y among one head's trajectories: does the ranking order the
    noise within a head (what head-balanced selection relies on), whatever it says about which head. NaN when no
    head's correlation is defined."""
    x, y = np.asarray(x), np.asarray(y)
    rho = [spearman(x[heads == h], y[heads == h]) for h in np.unique(heads)]
    rho = [r for r in rho if np.isfinite(r)]
    return float(np.mean(rho)) if rho else float("nan")


def top_k_overlap(a: np.ndarray, b: np.ndarray, k: int) -> float:
    """|top-k of a ∩ top-k of b| / k."""
    return len(set(top_k_indices(a, k).tolist()) & set(top_k_indices(b, k).tolist())) / k


def max_pair_difference(x: np.ndarray) -> np.ndarray:
    """x [K, Q, d] -> the difference vector x_i - x_j of each row's most distant pair of members, [Q, d]
    (the pair behind the DRIL / MOREL reward, ``rewards.max_pairwise_distance``)."""
    x = np.asarray(x, np.float64)
    kk = x.shape[0]
    i, j = np.triu_indices(kk, 1)
    diff = x[i] - x[j]  # [P, Q, d]
    best = np.argmax(np.sum(diff**2, -1), 0)  # [Q]
    return diff[best, np.arange(x.shape[1])]


def dimension_shares(diff: np.ndarray) -> np.ndarray:
    """Each dimension's share of the summed squared distance over the rows of diff [Q, d] -> [d] (sums to 1)."""
    sq = np.sum(np.asarray(diff, np.float64) ** 2, 0)
    total = sq.sum()
    return sq / total if total > 0 else np.zeros_like(sq)
