"""Table maths: success rates with Wilson 95% intervals."""

from __future__ import annotations

import math


def wilson_interval(successes: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion (default 95%)."""
    if n <= 0:
        raise ValueError("n: number of episodes must be positive")
    if not 0 <= successes <= n:
        raise ValueError(f"successes: {successes} is not within [0, {n}]")
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    # The interval always contains p (rounding can otherwise leave it a hair outside at 0 or n).
    return max(0.0, min(p, centre - half)), min(1.0, max(p, centre + half))
