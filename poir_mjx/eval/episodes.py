"""Evaluation episodes in either simulator, behind one call, and the test that compares the two."""

from __future__ import annotations

import numpy as np

from poir_mjx.cached import builder
from poir_mjx.core.agent import POIR
from poir_mjx.envs.env import make_env, make_params
from poir_mjx.eval import robosuite_eval
from poir_mjx.eval.methods import Method
from poir_mjx.rollout.evaluator import make_evaluator
from poir_mjx.rollout.sharding import run_batch

SIMULATORS = ("mjx", "robosuite")


@builder
def mjx_evaluator(task: str, method: Method, agent: POIR, steps: int, observation: str = "low_dim",
                  physics: str = "reference"):  # fmt: skip
    """One compiled MJX evaluator per (task, method, agent config, steps, observation, physics preset), reused across
    cells and runs."""
    env = make_env(task, observation=observation, physics=physics)
    if method.oracle:
        from poir_mjx.eval.oracle import oracle_policy

        return make_evaluator(env, oracle_policy(env, agent), steps)
    return make_evaluator(env, method.policy_fn(agent), steps)


def run_episodes(simulator: str, task: str, method: Method, agent: POIR, params, keys, sigma_init, sigma_action,
                 steps: int, workers: int = 2, progress: bool = True,
                 observation: str = "low_dim", physics: str = "reference") -> dict[str, np.ndarray]:  # fmt: skip
    """One episode per key (perturbations per episode), the agent seeing `observation` ("low_dim" or "object"), MJX
    stepping with the `physics` preset (robosuite: its own); {"first_success", "diverged", "steps"} as numpy arrays."""
    if simulator == "robosuite":
        if method.oracle:
            from poir_mjx.eval.oracle import RobosuiteOracle

            policy = RobosuiteOracle(agent)
        else:
            policy = method.policy_fn(agent)
        return robosuite_eval.evaluate(task, policy, params, keys, sigma_init, sigma_action, steps,
                                       workers, progress=progress, observation=observation)  # fmt: skip
    if simulator != "mjx":
        raise ValueError(f"simulator: {simulator!r} is not one of {SIMULATORS}")
    evaluator = mjx_evaluator(task, method, agent, steps, observation, physics)
    return run_batch(evaluator, params, keys, make_params(sigma_init, sigma_action))


def agreement_p_value(k1: int, n1: int, k2: int, n2: int) -> float:
    """Two-sided Fisher exact test that two success counts come from the same rate (small p: they differ)."""
    from scipy.stats import fisher_exact

    return float(fisher_exact([[k1, n1 - k1], [k2, n2 - k2]]).pvalue)
