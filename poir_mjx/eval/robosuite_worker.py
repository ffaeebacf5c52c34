"""A robosuite worker process for ``eval/robosuite_eval.py``: ``python -m poir_mjx.eval.robosuite_worker TASK N
[OBSERVATION]`` (the policy's observation, ``envs/layout.OBSERVATIONS``: "low_dim" unless given).

Reads pickled messages on stdin and answers each on stdout (robosuite's own prints go to stderr).
"""

from __future__ import annotations

import os
import pickle
import sys

import numpy as np

from poir_mjx.data.robomimic import robosuite_obs
from poir_mjx.envs.layout import observation_keys
from poir_mjx.eval.robosuite_state import restore, rollout_from, save


def flat_obs(o, observation: str = "low_dim") -> np.ndarray:
    """The policy's observation vector (float32: robomimic's low-dim keys, or the object-state alone for "object")
    from a robosuite observation dict."""
    return np.concatenate(list(robosuite_obs(o, observation_keys(observation)).values()))


def start_episode(task: str, seed: int, sigma_init: float, observation: str = "low_dim"):
    """A fresh robosuite environment for one episode, as every evaluation starts it: (env, action-noise generator,
    first observation vector). Built with the episode's seed and arm noise: robosuite rebuilds its model at every
    reset anyway (hard reset), and only construction seeds all of its draws (arm noise, object placement, Lift's
    cube size)."""
    from poir_mjx.envs.tasks import make_robosuite

    env = make_robosuite(task, seed=int(seed), initialization_noise={"magnitude": float(sigma_init), "type": "gaussian"})
    noise = np.random.default_rng(np.random.SeedSequence(int(seed)).spawn(1)[0])
    return env, noise, flat_obs(env.reset(), observation)


def serve(recv, send, task: str, n_envs: int, observation: str = "low_dim") -> None:
    """A process holding `n_envs` robosuite environments; answers reset/step/probe messages until "close".

    A reset or step is answered by (obs [n_envs, d], success [n_envs], diverged [n_envs]); an environment that
    is not stepping (diverged or unused) repeats its last observation (zeros before its first episode). A probe
    (the oracle control) is answered by (reached [n_envs, H, N, d],): each running environment's N candidate
    action sequences rolled out from its current state, which is then put back as it was (the episode, its
    action noise included, goes on as if never probed). The first message must be a "reset" with at least one
    episode.
    """
    import logging

    logging.getLogger("robosuite_logs").setLevel(logging.ERROR)
    envs, last = [None] * n_envs, [None] * n_envs
    noise, sig_a, alive = [None] * n_envs, np.zeros(n_envs), np.zeros(n_envs, bool)
    while True:
        msg = recv()
        if msg[0] == "close":
            break
        if msg[0] == "probe":  # ("probe", actions [n_envs, N, H, da] env units, skip [n_envs])
            send((probe(envs, last, alive & ~np.asarray(msg[2], bool), msg[1], observation),))
            continue
        success, diverged = np.zeros(n_envs, bool), np.zeros(n_envs, bool)
        if msg[0] == "reset":  # ("reset", [(seed, sigma_init, sigma_action), ...])
            alive[:] = False
            for j, (seed, si, sa) in enumerate(msg[1]):
                if envs[j] is not None:
                    envs[j].close()
                envs[j], noise[j], last[j] = start_episode(task, seed, si, observation)
                sig_a[j], alive[j] = float(sa), True
                success[j] = bool(envs[j]._check_success())
        else:  # ("step", actions [n_envs, 7], stop [n_envs]): end the flagged episodes, step the others
            actions = msg[1]
            alive &= ~np.asarray(msg[2], bool)
            for j in np.flatnonzero(alive):
                env = envs[j]
                a = np.asarray(actions[j], np.float64) + sig_a[j] * noise[j].standard_normal(actions.shape[1])
                try:
                    o, _, _, _ = env.step(a)
                    ok = bool(np.all(np.isfinite(env.sim.data.qpos)) and np.all(np.isfinite(env.sim.data.qvel)))
                except Exception:  # MuJoCo's instability errors: the episode diverged
                    ok = False
                if ok:
                    last[j], success[j] = flat_obs(o, observation), bool(env._check_success())
                else:
                    alive[j], diverged[j] = False, True
        width = next(len(x) for x in last if x is not None)
        send((np.stack([x if x is not None else np.zeros(width, np.float32) for x in last]), success, diverged))
    for env in envs:
        if env is not None:
            env.close()


def probe(envs, last, which: np.ndarray, actions: np.ndarray, observation: str) -> np.ndarray:
    """The candidate sequences actions[j] [N, H, da] rolled out from environment j's current state for every j in
    `which` (zeros elsewhere): [n_envs, H, N, d]; each environment is restored to its state afterwards."""
    width = next(len(x) for x in last if x is not None)
    n_envs, n, h = actions.shape[:3]
    reached = np.zeros((n_envs, h, n, width), np.float32)
    for j in np.flatnonzero(which):
        state = save(envs[j])
        reached[j] = rollout_from(envs[j], state, last[j], actions[j], lambda o: flat_obs(o, observation))[1:]
        restore(envs[j], state)
    return reached


def _die_with_parent() -> None:
    """Linux: a SIGTERM when the process that started this worker dies (killed sweeps leave no workers)."""
    import ctypes
    import signal

    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass  # not Linux: the worker ends at its next read of the closed pipe


def main() -> None:
    _die_with_parent()
    out = os.fdopen(os.dup(1), "wb")  # the message channel; fd 1 then points at stderr
    os.dup2(2, 1)
    inp = sys.stdin.buffer

    def send(x):
        pickle.dump(x, out)
        out.flush()

    observation = sys.argv[3] if len(sys.argv) > 3 else "low_dim"
    serve(lambda: pickle.load(inp), send, sys.argv[1], int(sys.argv[2]), observation)


if __name__ == "__main__":
    main()
