"""Episodes in robosuite's own simulator (the reference), with the same agent choosing the actions.

Episodes are spread over worker processes (``eval/robosuite_pool.py``), each stepping its share of
robosuite environments (MuJoCo C, robosuite's OSC_POSE controller); at every control step the main
process calls the compiled, batched policy (``jit(vmap(policy_fn))``) on the gathered observations,
so the agent code and its per-episode, per-step keys are those of the MJX evaluator
(``rollout/episode.py``). With ``overlap`` the workers form two groups: one group's actions are
computed while the other's environments step, so planning and physics run at the same time. By
default it is on only when a core is left for the planner: on 2 cores with 2 workers it made POIR-DRIL
collection slower (results/bench/robosuite-e2e.md).
Per episode: robosuite's reset noise on the arm's joints is ``sigma_init`` (Gaussian), Gaussian
noise of std ``sigma_action`` is added to every action, and robosuite draws the rest of the reset
(object pose, Lift's cube size) from a generator seeded by the episode's key. An episode stops
stepping once it succeeds (the success is counted) or its physics stops being finite (diverged).
"""

from __future__ import annotations

import os

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.cached import builder
from poir_mjx.eval.robosuite_pool import RobosuitePool

__all__ = ["RobosuitePool", "episode_streams", "evaluate", "collect", "run"]


def episode_streams(keys: jax.Array, steps: int):
    """Per episode: robosuite's reset seed and the policy's per-step keys, split as the MJX evaluator splits."""
    split = jax.vmap(jax.random.split)(keys)  # [B, 2, 2]: (reset key, run key) per episode
    seeds = np.asarray(jax.vmap(lambda k: jax.random.bits(k, (), jnp.uint32))(split[:, 0])).astype(np.int64)
    step_keys = jax.vmap(lambda k: jax.random.split(k, steps))(split[:, 1])  # [B, steps, 2]
    return seeds, step_keys


def evaluate(task: str, policy_fn, params, keys: jax.Array, sigma_init, sigma_action, steps: int,
             workers: int = 2, envs_per_worker: int = 16, progress: bool = True,
             overlap: bool | None = None, observation: str = "low_dim") -> dict[str, np.ndarray]:  # fmt: skip
    """Run len(keys) episodes of `steps` control steps in robosuite; the results of ``rollout.sharding.run_batch``.

    policy_fn: (params, obs, key) -> action, compiled here as a batch; or the oracle control
    (``eval/oracle.RobosuiteOracle``), which also rolls candidates out in the workers.

    keys: one PRNG key per episode (raw uint32 [B, 2]); sigma_init / sigma_action: [B]; observation: what the
    policy sees ("low_dim" or "object", ``envs/layout.OBSERVATIONS``).
    first_success counts control steps from 1, as the MJX environment does (-1: never).
    """
    return run(task, policy_fn, params, keys, sigma_init, sigma_action, steps, workers, envs_per_worker,
               record=False, overlap=overlap, progress=progress, observation=observation)[0]  # fmt: skip


def collect(task: str, policy_fn, params, keys: jax.Array, sigma_init, sigma_action, steps: int,
            workers: int = 2, envs_per_worker: int = 16, progress: bool = False, overlap: bool | None = None,
            observation: str = "low_dim"):  # fmt: skip
    """Episodes as ``evaluate`` runs them, with their transitions: (outcome, (obs, action, next_obs, valid)),
    each [B, steps, ...] as the MJX collector (``online/loop.make_collector``) returns them. The action is
    the policy's (before the environment's action noise); valid is False from the step after an
    episode's success on, on its diverging step and after it."""
    return run(task, policy_fn, params, keys, sigma_init, sigma_action, steps, workers, envs_per_worker,
               record=True, overlap=overlap, progress=progress, observation=observation)  # fmt: skip


def run(task, policy_fn, params, keys, sigma_init, sigma_action, steps, workers, envs_per_worker, *,
        record: bool, overlap: bool, progress: bool, observation: str = "low_dim"):  # fmt: skip
    from tqdm import tqdm

    keys = jnp.asarray(keys)
    n = keys.shape[0]
    si = np.broadcast_to(np.asarray(sigma_init, np.float64), (n,))
    sa = np.broadcast_to(np.asarray(sigma_action, np.float64), (n,))
    seeds, step_keys = episode_streams(keys, steps)
    workers = workers or os.cpu_count() or 1  # 0: one per core
    if overlap is None:  # overlapping pays only with a core left for the planner (bench robosuite)
        overlap = (os.cpu_count() or 1) > workers
    envs_per_worker = max(1, min(envs_per_worker, -(-n // workers)))
    workers = max(1, min(workers, -(-n // envs_per_worker)))
    from poir_mjx.eval.outcomes import OutcomeTracker, position_slices

    slices = position_slices(task, observation)
    out = _Episodes(n, steps, record, OutcomeTracker(n, slices) if slices is not None else None)
    act = policy_fn if getattr(policy_fn, "probes", False) else _ignoring_pool(batched_policy(policy_fn))
    bar = tqdm(total=n, desc=f"robosuite {task}", unit="ep", disable=not progress)
    with RobosuitePool(task, workers, envs_per_worker, observation) as pool:
        groups = pool.groups(2 if overlap else 1)
        for start in range(0, n, pool.size):
            idx = np.arange(start, min(start + pool.size, n))
            obs, _ = pool.reset([(int(seeds[i]), float(si[i]), float(sa[i])) for i in idx])
            if out.outcomes is not None:
                out.outcomes.begin(idx, obs[: len(idx)])
            # padding slots repeat the first episode (a fixed batch: one compilation) and never count
            rows = np.concatenate([idx, np.full(pool.size - len(idx), idx[0])])
            real = np.arange(pool.size) < len(idx)
            _wave(pool, groups, act, params, obs, rows, real, step_keys, steps, out)
            bar.update(len(idx))
    bar.close()
    result = {"first_success": out.first, "diverged": out.diverged, "steps": np.full(n, steps)}
    if out.outcomes is not None:  # how each episode ended (eval/outcomes.py)
        result["outcome"], result["moved_object"] = out.outcomes.labels(out.first, out.diverged)
    return result, out.transitions()


@builder(maxsize=16)
def batched_policy(policy_fn):
    """jit(vmap(policy_fn)) over (obs, key) rows, one per policy (an agent's bound method counts as one), so
    repeated calls (an online run's rounds) are not traced and compiled again."""
    return jax.jit(jax.vmap(policy_fn, in_axes=(None, 0, 0)))


def _ignoring_pool(act):
    """A batched policy called as the oracle is (``eval/oracle.RobosuiteOracle``: pool, worker ids and ended
    episodes first), which it does not need."""
    return lambda pool, wids, settled, params, obs, keys: act(params, obs, keys)


class _Episodes:
    """What the episodes have done so far: first success, divergence, where the hand and object are (``outcomes``,
    where the observation has them) and (if recorded) transitions."""

    def __init__(self, n: int, steps: int, record: bool, outcomes=None):
        self.first, self.diverged = np.full(n, -1, np.int64), np.zeros(n, bool)
        self.n, self.steps, self.record, self.outcomes = n, steps, record, outcomes
        self.obs = self.act = self.next_obs = None
        self.valid = np.zeros((n, steps), bool)

    def settled(self, rows, real):
        return ~real | (self.first[rows] >= 0) | self.diverged[rows]

    def sent(self, rows, live, t, obs, action):
        if not self.record:
            return
        if self.obs is None:
            self.obs = np.zeros((self.n, self.steps, obs.shape[1]), np.float32)
            self.next_obs = np.zeros_like(self.obs)
            self.act = np.zeros((self.n, self.steps, action.shape[1]), np.float32)
        self.obs[rows[live], t], self.act[rows[live], t] = obs[live], action[live]

    def answered(self, rows, live, t, obs, success, div):
        r = rows[live]
        new = success[live] & (self.first[r] < 0)
        self.first[r[new]] = t + 1
        self.diverged[r[div[live]]] = True
        if self.outcomes is not None:
            self.outcomes.observe(r, obs[live])
        if self.record:
            self.valid[r, t] = ~div[live]
            self.next_obs[r, t] = obs[live]

    def transitions(self):
        """(obs, action, next_obs, valid), or None if not recorded or no step was taken."""
        return None if self.obs is None else (self.obs, self.act, self.next_obs, self.valid)


def _wave(pool, groups, act, params, obs, rows, real, step_keys, steps, out: _Episodes) -> None:
    """One wave of episodes to the end: each group in turn receives its last step's reply, then has its
    next actions computed and sent, while the other group's environments are still stepping."""
    in_flight = [None] * len(groups)  # per group: (t, live mask) of the step sent and not yet answered
    t_next = [0] * len(groups)
    while True:
        busy = False
        for g, (wids, sl) in enumerate(groups):
            if in_flight[g] is not None:
                t, live = in_flight[g]
                o2, success, div = pool.receive(wids)
                out.answered(rows[sl], live, t, o2, success, div)
                obs[sl], in_flight[g] = o2, None
            settled = out.settled(rows[sl], real[sl])
            t = t_next[g]
            if t >= steps or settled.all():
                continue
            a = np.asarray(act(pool, wids, settled, params, jnp.asarray(obs[sl]), step_keys[rows[sl], t]))
            pool.send_step(wids, a, settled)
            out.sent(rows[sl], ~settled, t, obs[sl], a)
            in_flight[g], t_next[g], busy = (t, ~settled), t + 1, True
        if not busy:
            return
