"""How the planner ranks its candidates by default, by name: "balanced" (the default) or "paper".

Issue 41's forensics measured two mechanisms that make the printed ranking worse than chance, on Lift and on
PickPlaceCan (docs/diagnose.md): the **head lottery** (trajectory n keeps head n mod K for the whole rollout, so
its return mostly says which head's model it ran through; the top-k then comes from one head in 9 of 10 planner
calls) and L2's **geometry** (two-thirds of L2's squared distance is the hand's and object's quaternions). Their
fixes, together, are "balanced":

- ``planner.selection = "head_balanced"``: the best top_k / K trajectories of every head, averaged over the heads,
  so the ranking chooses noise within a head, never which head (core/selection.py);
- ``planner.l2_dims`` = every observation dimension but the quaternions', read from the observation's layout.

"paper" is the algorithm as printed (the k best returns, L2 over every dimension): the ranking of every run
published before "balanced" became the default (2026-12-06). A sweep's ``ranking`` field and ``eval --ranking``
pick one; a ``planner.*`` override still wins over either.
"""

from __future__ import annotations

import dataclasses
from typing import Literal, Sequence, get_args

from poir_mjx.core.config import POIRConfig

Ranking = Literal["balanced", "paper"]
RANKINGS = get_args(Ranking)
DEFAULT_RANKING: Ranking = "balanced"


def quaternion_free(groups: Sequence[str]) -> tuple[int, ...]:
    """The observation dimensions outside the quaternions, given each dimension's group (envs/layout.obs_groups)."""
    return tuple(i for i, g in enumerate(groups) if g != "quaternion")


def with_ranking(cfg: POIRConfig, ranking: str, groups: Sequence[str]) -> POIRConfig:
    """`cfg` with the planner fields `ranking` names, for an observation whose dimensions have `groups`."""
    if ranking == "paper":
        return cfg
    if ranking != "balanced":
        raise ValueError(f"ranking: {ranking!r} is not one of {list(RANKINGS)}")
    planner = dataclasses.replace(cfg.planner, selection="head_balanced", l2_dims=quaternion_free(groups))
    return dataclasses.replace(cfg, planner=planner)
