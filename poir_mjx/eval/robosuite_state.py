"""A robosuite environment's state kept and put back, and action sequences rolled out from a kept state: what the
forensics (``diagnose/simulate.py``) and the oracle control in robosuite (``eval/oracle.py``) rest on."""

from __future__ import annotations

from typing import Callable

import numpy as np


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


def rollout_from(env, state: dict, start_obs: np.ndarray, actions: np.ndarray,
                 observe: Callable[[dict], np.ndarray]) -> np.ndarray:  # fmt: skip
    """actions [N, H, da] (env units), each sequence stepped from `state` (restored before each) -> the observations
    [H + 1, N, ds] (`start_obs` first; observe(robosuite's dict) -> vector). A step that raises or leaves the finite
    range repeats the last finite observation. The environment is left in the last sequence's end state."""
    n, h, _ = actions.shape
    out = np.empty((h + 1, n, start_obs.shape[0]), np.float32)
    out[0] = start_obs
    for i in range(n):
        restore(env, state)
        last = start_obs
        for t in range(h):
            try:
                o, _, _, _ = env.step(np.asarray(actions[i, t], np.float64))
                obs = observe(o)
                last = obs if np.all(np.isfinite(obs)) else last
            except Exception:  # MuJoCo's instability errors: keep the last state
                pass
            out[t + 1, i] = last
    return out
