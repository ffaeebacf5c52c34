"""The methods the evaluator knows, in one registry.

Each method names the agent it needs (how it is trained) and how it acts. Agents are trained once
per (task, preset, kind) and shared: BC and EBC use the un-normalised BC ensemble ("policy"
agent; BC is its first network), every POIR variant uses the normalised BC + world-model
ensembles ("poir" agent) with its own planner settings. "POIR-<reward> online" starts from the same
offline "poir" agent and keeps training its world model on its own deployment transitions
(poir_mjx/online); its cell is the success after fine-tuning, its learning curve is kept beside it.
The baselines (DAC, ValueDICE, SQIL, PPO+DRIL) train their own policies in each cell's perturbed MJX
environment from the same expert data (poir_mjx/baselines); their cells hold the trained policy's success.
"""

from __future__ import annotations

import dataclasses
from typing import Callable

from poir_mjx.core.agent import POIR
from poir_mjx.baselines.registry import BASELINES
from poir_mjx.core.config import PlannerConfig, POIRConfig, offline_config


class UnknownMethodError(ValueError):
    pass


@dataclasses.dataclass(frozen=True)
class Method:
    name: str
    agent_kind: str  # "policy" (BC ensemble, no normalisation), "poir" (normalised BC + world model) or "baseline"
    act: str  # "bc", "ebc" (for a "poir" agent: its prior alone), "plan" or "learned" (a baseline's own policy)
    reward: str | None = None
    use_prior: bool = True
    selection: str | None = None  # planner.selection: "random" is the control without the reward's ranking; None: the
    # config's (top_k by default, or an option such as head_balanced set for the whole run)
    online: bool = False  # fine-tune the world model on deployment data before the evaluation
    oracle: bool = False  # rank the planner's candidates by their returns in the true simulator (eval/oracle.py)
    description: str = ""

    @property
    def is_baseline(self) -> bool:
        """Trained online from scratch per cell by its own learner (poir_mjx/baselines), not from a POIR agent."""
        return self.agent_kind == "baseline"

    @property
    def has_curve(self) -> bool:
        """Its cells keep a learning curve (online fine-tuning or a baseline's training)."""
        return self.online or self.is_baseline

    def agent_config(self, base: POIRConfig) -> POIRConfig:
        """The config this method's agent is trained and run with (online settings only for online methods)."""
        if not self.online:
            base = offline_config(base)
        if self.agent_kind == "policy":
            return dataclasses.replace(base, normalize=False)
        planner = base.planner
        if self.reward is not None:
            planner = dataclasses.replace(planner, reward=self.reward, use_prior=self.use_prior,
                                          selection=self.selection or planner.selection)  # fmt: skip
        return dataclasses.replace(base, normalize=True, planner=planner)

    def training_config(self, base: POIRConfig) -> POIRConfig:
        """What determines the offline weights (how the planner uses them and online settings do not): the
        checkpoint key."""
        cfg = offline_config(self.agent_config(base))
        default = PlannerConfig()
        how_it_plans = ("reward", "use_prior", "selection", "disagreement", *PlannerConfig.HASH_AT_DEFAULT_OMITS)
        planner = dataclasses.replace(base.planner, **{f: getattr(default, f) for f in how_it_plans})
        return dataclasses.replace(cfg, planner=planner)

    def policy_fn(self, agent: POIR) -> Callable:
        """(params, obs_vector, key) -> action."""
        if self.act == "bc":
            return lambda p, o, k: agent.bc_action(p, o)
        if self.act == "ebc":
            return lambda p, o, k: agent.ebc_action(p, o)
        return agent.plan


METHODS: dict[str, Method] = {
    m.name: m
    for m in (
        Method("BC", "policy", "bc", description="one BC network (the ensemble's first)"),
        Method("EBC", "policy", "ebc", description="mean of the K BC networks"),
        Method("POIR-L2", "poir", "plan", "l2", description="planner, reward: distance to the nearest expert state"),
        Method("POIR-DRIL", "poir", "plan", "dril", description="planner, reward: BC-ensemble disagreement"),
        Method("POIR-MOREL", "poir", "plan", "morel", description="planner, reward: world-model disagreement"),
        Method("POIR-noprior", "poir", "plan", "dril", use_prior=False,
               description="ablation: uniform candidate actions instead of the BC prior"),  # fmt: skip
        Method("POIR-prior", "poir", "ebc", description="control: POIR's BC prior alone (mean of its heads, no planning)"),
        Method("POIR-random", "poir", "plan", "dril", selection="random",
               description="control: the planner's top-k drawn uniformly among its trajectories (noise, no ranking)"),
        *(Method(f"POIR-{r.upper()} oracle", "poir", "plan", r, oracle=True,
                 description=f"control: the planner's candidates ranked by their true {r.upper()} returns, rolled out "
                             "in the true simulator itself (an upper bound on any ranking; MJX or robosuite)")
          for r in ("l2", "dril")),  # fmt: skip
        *(Method(f"POIR-{r.upper()} online", "poir", "plan", r, online=True,
                 description=f"POIR-{r.upper()} after online world-model fine-tuning in the cell's perturbed environment")
          for r in ("l2", "dril", "morel")),  # fmt: skip
        *(Method(b.name, "baseline", "learned", description=b.description) for b in BASELINES.values()),
    )
}


def get_method(name: str) -> Method:
    if name not in METHODS:
        raise UnknownMethodError(f"method: unknown method {name!r}; expected one of {', '.join(METHODS)}")
    return METHODS[name]
