"""Train one baseline in one deployment environment: chunks of compiled training, evaluations, checkpoints.

The loop around a learner's compiled ``train``: every ``eval_every`` environment steps (and at step 0) the deterministic
policy runs the evaluation episodes through the project's MJX evaluator (the same compiled evaluator as every other
method), and the whole training state is checkpointed (atomically, restored by name); a run started again with the same
checkpoint path continues from the last finished chunk.
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path
from typing import Any

import jax
import numpy as np

from poir_mjx.baselines.learner import ExpertData, Learner
from poir_mjx.core.agent import check_losses
from poir_mjx.rollout.evaluator import make_evaluator, success_record
from poir_mjx import run_state as ock
from poir_mjx.rollout.sharding import run_batch


@dataclasses.dataclass
class BaselineResult:
    policy_params: Any
    curve: list[dict]  # env_steps, successes, episodes, success_rate, diverged, imitation_reward, wall_s
    resumed_from_env_steps: int


def expert_data(tr) -> ExpertData:
    """ExpertData from a dataset's ``Transitions`` (demos concatenated; their starts and lengths mark the ends)."""
    n = tr.obs.shape[0]
    initial, terminal = np.zeros(n, bool), np.zeros(n, bool)
    initial[np.asarray(tr.demo_starts)] = True
    terminal[np.asarray(tr.demo_starts) + np.asarray(tr.demo_lengths) - 1] = True
    f32 = lambda x: np.asarray(x, np.float32)  # noqa: E731
    return ExpertData(f32(tr.obs), f32(tr.actions), f32(tr.next_obs), terminal, initial)


def chunk_iterations(env_steps_per_iteration: int, eval_every: int) -> int:
    """Training iterations between two evaluations (at least one)."""
    return max(1, eval_every // max(1, env_steps_per_iteration))


def train_baseline(learner: Learner, env, expert: ExpertData, env_params, eval_keys: jax.Array, eval_steps: int,
                   key: jax.Array, *, total_env_steps: int, eval_every: int, env_steps_per_iteration: int,
                   checkpoint_path: str | Path | None = None, config_hash: str = "",
                   progress: bool = False) -> BaselineResult:  # fmt: skip
    """Train `learner` in `env` perturbed by `env_params` (scalar noise levels) until `total_env_steps`.

    eval_keys: one key per evaluation episode, the same at every evaluation (a paired learning curve).
    """
    from tqdm import tqdm

    state = learner.init(key, expert, env_params)  # before policy_fn: a learner may size its policy from the data
    evaluator = make_evaluator(env, learner.policy_fn(), eval_steps)
    n_eval = eval_keys.shape[0]
    eval_params = jax.tree_util.tree_map(lambda x: np.broadcast_to(np.asarray(x), (n_eval,)), env_params)
    curve: list[dict] = []
    path = Path(checkpoint_path) if checkpoint_path is not None else None
    if path is not None and path.exists():
        state, meta = ock.load(path, state, config_hash)
        curve = meta["curve"]
    resumed = int(learner.env_steps(state))

    def evaluate(st, reward) -> dict:
        t0 = time.perf_counter()
        res = run_batch(evaluator, learner.policy_params(st), eval_keys, eval_params)
        return {"env_steps": int(learner.env_steps(st)), **success_record(res, time.perf_counter() - t0),
                "imitation_reward": reward}

    def save():
        if path is not None:
            ock.save(path, state, {"config_hash": config_hash, "curve": curve})

    if not curve:
        curve.append(evaluate(state, None))
        save()
    iters = chunk_iterations(env_steps_per_iteration, eval_every)
    chunks = math.ceil(max(0, total_env_steps - resumed) / (iters * env_steps_per_iteration))
    bar = tqdm(total=total_env_steps, initial=resumed, desc=learner.name, unit="step", disable=not progress)
    for _ in range(chunks):
        before = int(learner.env_steps(state))
        state, metrics = learner.train(state, iters)
        check_losses(metrics, f"{learner.name} at {int(learner.env_steps(state))} environment steps",
                     "the baseline's learning rates")  # fmt: skip
        reward = float(np.nanmean(np.asarray(metrics["imitation_reward"])))
        curve.append(evaluate(state, reward))
        save()
        bar.update(int(learner.env_steps(state)) - before)
        bar.set_postfix(success=f"{curve[-1]['success_rate']:.2f}", reward=f"{reward:.3f}")
    bar.close()
    return BaselineResult(learner.policy_params(state), curve, resumed)
