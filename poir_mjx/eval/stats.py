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
