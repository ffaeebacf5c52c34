"""Evaluation in robosuite's own simulator (the reference), with the same agent choosing the actions.

Episodes are spread over worker processes, each stepping its share of robosuite environments
(MuJoCo C, robosuite's OSC_POSE controller); at every control step the main process gathers all
observations and calls the compiled, batched policy once (``jit(vmap(policy_fn))``), so the agent
code and its per-episode, per-step keys are those of the MJX evaluator (``rollout/episode.py``).
Per episode: robosuite's reset noise on the arm's joints is ``sigma_init`` (Gaussian), Gaussian
noise of std ``sigma_action`` is added to every action, and robosuite draws the rest of the reset
(object pose, Lift's cube size) from a generator seeded by the episode's key. An episode whose
physics stops being finite is marked diverged and frozen, as in MJX.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.optional import require_robosuite


class RobosuitePool:
    """`workers` processes (``python -m poir_mjx.eval.robosuite_worker``) with `envs_per_worker` robosuite
    environments each, spoken to over pipes; a context manager. Plain subprocesses rather than
    multiprocessing: nothing of the calling program (jax's threads, an unguarded __main__) is copied."""

    def __init__(self, task: str, workers: int, envs_per_worker: int):
        require_robosuite("evaluating in robosuite (simulator: robosuite)")
        self.size, self.per = workers * envs_per_worker, envs_per_worker
        cmd = [sys.executable, "-m", "poir_mjx.eval.robosuite_worker", task, str(envs_per_worker)]
        env = {**os.environ, "JAX_PLATFORMS": "cpu", "OMP_NUM_THREADS": "1"}
        self.procs = [subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env) for _ in range(workers)]

    def _exchange(self, messages):
        def dead(p):
            return RuntimeError(f"robosuite worker exited with status {p.wait()} (its error is printed above)")

        for p, m in zip(self.procs, messages):
            try:
                pickle.dump(m, p.stdin)
                p.stdin.flush()
            except (BrokenPipeError, OSError):
                raise dead(p) from None
        replies = []
        for p in self.procs:
            try:
                replies.append(pickle.load(p.stdout))
            except EOFError:
                raise dead(p) from None
        return tuple(np.concatenate(parts) for parts in zip(*replies))

    def reset(self, episodes: list[tuple[int, float, float]]):
        """Start up to `size` episodes (seed, sigma_init, sigma_action); returns (obs [size, d], success [size])."""
        per = [episodes[w * self.per : (w + 1) * self.per] for w in range(len(self.procs))]
        obs, success, _ = self._exchange([("reset", p) for p in per])
        return obs, success

    def step(self, actions: np.ndarray, stop: np.ndarray | None = None):
        """One control step of every running episode, after ending those flagged in `stop` [size];
        returns (obs, success, diverged) [size]."""
        stop = np.zeros(self.size, bool) if stop is None else stop
        sl = [slice(w * self.per, (w + 1) * self.per) for w in range(len(self.procs))]
        return self._exchange([("step", actions[s], stop[s]) for s in sl])

    def close(self):
        for p in self.procs:
            try:
                pickle.dump(("close",), p.stdin)
                p.stdin.close()
            except (BrokenPipeError, OSError):
                pass
        for p in self.procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def episode_streams(keys: jax.Array, steps: int):
    """Per episode: robosuite's reset seed and the policy's per-step keys, split as the MJX evaluator splits."""
    split = jax.vmap(jax.random.split)(keys)  # [B, 2, 2]: (reset key, run key) per episode
    seeds = np.asarray(jax.vmap(lambda k: jax.random.bits(k, (), jnp.uint32))(split[:, 0])).astype(np.int64)
    step_keys = jax.vmap(lambda k: jax.random.split(k, steps))(split[:, 1])  # [B, steps, 2]
    return seeds, step_keys


def evaluate(task: str, policy_fn, params, keys: jax.Array, sigma_init, sigma_action, steps: int,
             workers: int = 2, envs_per_worker: int = 16, progress: bool = True) -> dict[str, np.ndarray]:  # fmt: skip
    """Run len(keys) episodes of `steps` control steps in robosuite; the results of ``rollout.sharding.run_batch``.

    keys: one PRNG key per episode (raw uint32 [B, 2]); sigma_init / sigma_action: [B].
    first_success counts control steps from 1, as the MJX environment does (-1: never). Episodes
    stop stepping once they succeed (the success is already counted), so a wave ends early.
    """
    from tqdm import tqdm

    keys = jnp.asarray(keys)
    n = keys.shape[0]
    si = np.broadcast_to(np.asarray(sigma_init, np.float64), (n,))
    sa = np.broadcast_to(np.asarray(sigma_action, np.float64), (n,))
    seeds, step_keys = episode_streams(keys, steps)
    envs_per_worker = max(1, min(envs_per_worker, -(-n // workers)))
    workers = max(1, min(workers, -(-n // envs_per_worker)))
    first = np.full(n, -1, np.int64)
    diverged = np.zeros(n, bool)
    act = jax.jit(jax.vmap(policy_fn, in_axes=(None, 0, 0)))
    bar = tqdm(total=n, desc=f"robosuite {task}", unit="ep", disable=not progress)
    with RobosuitePool(task, workers, envs_per_worker) as pool:
        for start in range(0, n, pool.size):
            idx = np.arange(start, min(start + pool.size, n))
            m = len(idx)
            obs, _ = pool.reset([(int(seeds[i]), float(si[i]), float(sa[i])) for i in idx])
            rows = np.concatenate([idx, np.full(pool.size - m, idx[0])])  # a fixed batch: one compilation
            for t in range(steps):
                # An episode that has succeeded or diverged is settled: its environment stops stepping.
                settled = np.concatenate([(first[idx] >= 0) | diverged[idx], np.ones(pool.size - m, bool)])
                if settled.all():
                    break
                a = np.asarray(act(params, jnp.asarray(obs), step_keys[rows, t]))
                obs, success, div = pool.step(a, settled)
                new = success[:m] & (first[idx] < 0) & ~diverged[idx]
                first[idx[new]] = t + 1
                diverged[idx] |= div[:m]
            bar.update(m)
    bar.close()
    return {"first_success": first, "diverged": diverged, "steps": np.full(n, steps)}
