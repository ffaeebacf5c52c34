"""The true simulator's side of the forensics (robosuite, MuJoCo C): a cell's episodes re-run with its keys, their
states kept every few steps, and candidate action sequences rolled out from a kept state (its state restored)."""

from __future__ import annotations

import dataclasses

import numpy as np

from poir_mjx.eval.robosuite_state import rollout_from, save
from poir_mjx.eval.robosuite_worker import flat_obs, start_episode


@dataclasses.dataclass
class Snapshot:
    """A state an episode visited, where the planner is taken apart."""

    episode: int
    step: int
    obs: np.ndarray  # [ds] the policy's observation
    key: np.ndarray  # the planner's key at this step (raw uint32 [2])
    sim_state: dict  # what ``save`` keeps: MuJoCo's state and robosuite's own (step counter, gripper ramps)


@dataclasses.dataclass
class Episode:
    obs: np.ndarray  # [T + 1, ds]
    actions: np.ndarray  # [T, da] the policy's actions (env units; no action noise: the forensics use none)
    success_step: int  # control steps until success (from 1), -1: never


def run_episode(task: str, seed: int, sigma_init: float, act, step_keys: np.ndarray, steps: int, every: int,
                episode: int) -> tuple[Episode, list[Snapshot]]:  # fmt: skip
    """One episode in robosuite from its seed and arm noise, acting with act(obs, key) -> env action, stopping at
    success (as the evaluator counts it) or after `steps`; a Snapshot at steps 0, every, 2 every, ..."""
    env, _, obs = start_episode(task, seed, sigma_init)
    try:
        states, actions, snaps, success = [obs], [], [], -1
        for t in range(steps):
            if t % every == 0:
                snaps.append(Snapshot(episode, t, obs, np.asarray(step_keys[t]), save(env)))
            a = np.asarray(act(obs, step_keys[t]), np.float64)
            o, _, _, _ = env.step(a)
            obs = flat_obs(o)
            states.append(obs)
            actions.append(a)
            if env._check_success():
                success = t + 1
                break
        return Episode(np.stack(states), np.stack(actions), success), snaps
    finally:
        env.close()


class Oracle:
    """Candidate action sequences rolled out in robosuite from snapshots of one episode's environment."""

    def __init__(self, task: str, seed: int, sigma_init: float):
        self.env, _, _ = start_episode(task, seed, sigma_init)

    def rollout(self, snap: Snapshot, actions: np.ndarray) -> np.ndarray:
        """actions [N, H, da] (env units) -> observations [H + 1, N, ds] (the snapshot's first; a step that raises
        or leaves the finite range repeats the last finite observation)."""
        return rollout_from(self.env, snap.sim_state, snap.obs, actions, flat_obs)

    def close(self) -> None:
        self.env.close()
