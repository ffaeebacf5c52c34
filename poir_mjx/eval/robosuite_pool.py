"""Worker processes holding robosuite environments, spoken to over pipes (``eval/robosuite_worker.py``).

Steps are sent and answered separately (``send_step`` / ``receive``), per group of workers, so the
caller can compute one group's actions while another group's environments step.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys

import numpy as np

from poir_mjx.envs.layout import observation_keys
from poir_mjx.optional import require_robosuite


class RobosuitePool:
    """`workers` processes (``python -m poir_mjx.eval.robosuite_worker``) with `envs_per_worker` robosuite
    environments each, answering with the policy's `observation` ("low_dim" or "object"); a context manager. Plain
    subprocesses rather than multiprocessing: nothing of the calling program (jax's threads, an unguarded __main__) is
    copied. Environment slot i lives in worker i // envs_per_worker."""

    def __init__(self, task: str, workers: int, envs_per_worker: int, observation: str = "low_dim"):
        require_robosuite("evaluating in robosuite (simulator: robosuite)")
        observation_keys(observation)  # an unknown observation fails here, not in every worker
        self.size, self.per = workers * envs_per_worker, envs_per_worker
        cmd = [sys.executable, "-m", "poir_mjx.eval.robosuite_worker", task, str(envs_per_worker), observation]
        env = {**os.environ, "JAX_PLATFORMS": "cpu", "OMP_NUM_THREADS": "1"}
        self.procs = [subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env) for _ in range(workers)]

    def groups(self, count: int) -> list[tuple[list[int], slice]]:
        """The workers split into `count` (at most one per worker) contiguous groups: (worker ids, slots)."""
        bounds = np.linspace(0, len(self.procs), min(count, len(self.procs)) + 1).round().astype(int)
        return [(list(range(a, b)), slice(a * self.per, b * self.per)) for a, b in zip(bounds[:-1], bounds[1:])]

    @staticmethod
    def _dead(p):
        return RuntimeError(f"robosuite worker exited with status {p.wait()} (its error is printed above)")

    def _send(self, wids, messages) -> None:
        for w, m in zip(wids, messages):
            p = self.procs[w]
            try:
                pickle.dump(m, p.stdin)
                p.stdin.flush()
            except (BrokenPipeError, OSError):
                raise self._dead(p) from None

    def receive(self, wids) -> tuple[np.ndarray, ...]:
        """The replies of workers `wids` to their last message: (obs, success, diverged) over their slots."""
        replies = []
        for w in wids:
            try:
                replies.append(pickle.load(self.procs[w].stdout))
            except EOFError:
                raise self._dead(self.procs[w]) from None
        return tuple(np.concatenate(parts) for parts in zip(*replies))

    def reset(self, episodes: list[tuple[int, float, float]]):
        """Start up to `size` episodes (seed, sigma_init, sigma_action); returns (obs [size, d], success [size])."""
        wids = list(range(len(self.procs)))
        self._send(wids, [("reset", episodes[w * self.per : (w + 1) * self.per]) for w in wids])
        obs, success, _ = self.receive(wids)
        return obs, success

    def send_step(self, wids, actions: np.ndarray, stop: np.ndarray) -> None:
        """One control step of the running episodes of workers `wids` (actions and stop flags over their
        slots), after ending those flagged in `stop`; answered by ``receive(wids)``."""
        self._send(wids, [("step", actions[i * self.per : (i + 1) * self.per], stop[i * self.per : (i + 1) * self.per])
                          for i in range(len(wids))])  # fmt: skip

    def probe(self, wids, actions: np.ndarray, skip: np.ndarray) -> np.ndarray:
        """The oracle's rollouts: actions [slots of `wids`, N, H, da] (env units) rolled out from each running,
        not `skip`ped environment's current state, which stays as it was; returns the observations reached
        [slots, H, N, d] (zeros where not rolled out)."""
        self._send(wids, [("probe", actions[i * self.per : (i + 1) * self.per], skip[i * self.per : (i + 1) * self.per])
                          for i in range(len(wids))])  # fmt: skip
        return self.receive(wids)[0]

    def step(self, actions: np.ndarray, stop: np.ndarray | None = None):
        """One control step of every running episode, after ending those flagged in `stop` [size];
        returns (obs, success, diverged) [size]."""
        wids = list(range(len(self.procs)))
        self.send_step(wids, actions, np.zeros(self.size, bool) if stop is None else stop)
        return self.receive(wids)

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
