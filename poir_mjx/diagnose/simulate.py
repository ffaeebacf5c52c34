"""The true simulator's side of the forensics (robosuite, MuJoCo C): a cell's episodes re-run with its keys, their
states kept every few steps, and candidate action sequences rolled out from a kept state (its state restored)."""

from __future__ import annotations

import dataclasses

import numpy as np

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


def save(env) -> dict:
    """Everything a robosuite step depends on: MuJoCo's state (time, qpos, qvel, actuator activations), the solver's
    warm start, robosuite's step counter and each gripper's command ramp (robosuite's grippers move their command
    towards the action's sign by a fixed speed per step: state outside MuJoCo)."""
    d = env.sim.data
    return {"mj": np.asarray(env.sim.get_state().flatten(), np.float64).copy(), "warmstart": d.qacc_warmstart.copy(),
            "timestep": env.timestep,
            "grippers": [{arm: np.copy(g.current_action) for arm, g in r.gripper.items()} for r in env.robots]}


def restore(env, state: dict) -> None:
    """Put robosuite back in a ``save``d state; the controllers read the robot's state afresh at their next action
    (robosuite's OSC computes its goal from the achieved pose)."""
    env.sim.set_state_from_flattened(state["mj"])
    env.sim.data.qacc_warmstart[:] = state["warmstart"]
    env.sim.forward()
    env.timestep, env.done = state["timestep"], False
    for robot, grippers in zip(env.robots, state["grippers"]):
        for arm, ramp in grippers.items():
            robot.gripper[arm].current_action = np.copy(ramp)
        for part in robot.composite_controller.part_controllers.values():
            part.new_update = True


class Oracle:
    """Candidate action sequences rolled out in robosuite from snapshots of one episode's environment."""

    def __init__(self, task: str, seed: int, sigma_init: float):
        self.env, _, _ = start_episode(task, seed, sigma_init)

    def rollout(self, snap: Snapshot, actions: np.ndarray) -> np.ndarray:
        """actions [N, H, da] (env units) -> observations [H + 1, N, ds] (the snapshot's first; a step that raises
        or leaves the finite range repeats the last finite observation)."""
        n, h, _ = actions.shape
        out = np.empty((h + 1, n, snap.obs.shape[0]), np.float32)
        out[0] = snap.obs
        for i in range(n):
            restore(self.env, snap.sim_state)
            last = snap.obs
            for t in range(h):
                try:
                    o, _, _, _ = self.env.step(np.asarray(actions[i, t], np.float64))
                    obs = flat_obs(o)
                    last = obs if np.all(np.isfinite(obs)) else last
                except Exception:  # MuJoCo's instability errors: keep the last state
                    pass
                out[t + 1, i] = last
        return out

    def close(self) -> None:
        self.env.close()
