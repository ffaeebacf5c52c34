"""Table maths: success rates with Wilson 95% intervals (scipy's)."""

from __future__ import annotations


def wilson_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion (scipy.stats.binomtest(...).proportion_ci)."""
    from scipy.stats import binomtest

    if n <= 0:
        raise ValueError("n: number of episodes must be positive")
    if not 0 <= successes <= n:
        raise ValueError(f"successes: {successes} is not within [0, {n}]")
    ci = binomtest(int(successes), int(n)).proportion_ci(confidence_level=confidence, method="wilson")
    p = successes / n
    # The interval always contains p (rounding can otherwise leave it a hair outside at 0 or n).
    return max(0.0, min(p, float(ci.low))), min(1.0, max(p, float(ci.high)))


def pooled_p_value(cells: list[tuple[int, int, int, int]]) -> float:
    """Cochran-Mantel-Haenszel test over noise cells (strata) that two methods' success rates are the same in every
    cell (two-sided, with the continuity correction, as R's mantelhaen.test); cells: (k1, n1, k2, n2) each.

    One number for "does A beat B across the grid": five cells each short of significance can add up, or not."""
    from scipy.stats import chi2

    diff, var = 0.0, 0.0
    for k1, n1, k2, n2 in cells:
        n, succ = n1 + n2, k1 + k2
        if n < 2:
            continue
        diff += k1 - n1 * succ / n
        var += n1 * n2 * succ * (n - succ) / (n * n * (n - 1))
    if var <= 0:  # every cell all successes or all failures: no evidence of a difference
        return 1.0
    return float(chi2.sf(max(abs(diff) - 0.5, 0.0) ** 2 / var, 1))
