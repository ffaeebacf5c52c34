"""A kinematic stand-in for Lift that the scripted expert can drive through all its phases in milliseconds:
the hand moves by the action's position part, turns about z by its yaw part, and carries the cube once the
fingers close within 2 cm of the grasp point. No physics; it exists to pin the expert's actions, not to test a grasp."""

from __future__ import annotations

import numpy as np

from poir_mjx.data.expert_episodes import _jit_expert


def _quat_xyzw(yaw: float, down: bool) -> np.ndarray:
    """(x, y, z, w) of a turn by `yaw` about world z, after a half turn about x when `down` (hand pointing down)."""
    c, s = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.array([c, s, 0.0, 0.0] if down else [0.0, 0.0, s, c], np.float32)


def obs(eef, hand_yaw, cube, cube_yaw) -> dict:
    o = np.zeros(10, np.float32)
    o[:3], o[3:7], o[7:] = cube, _quat_xyzw(cube_yaw, False), np.asarray(cube) - np.asarray(eef)
    return {"robot0_eef_pos": np.asarray(eef, np.float32), "robot0_eef_quat": _quat_xyzw(hand_yaw, True),
            "robot0_gripper_qpos": np.zeros(2, np.float32), "object": o}  # fmt: skip


def run(seed: int, steps: int = 60, style: str = "scripted", start=(0.02, -0.03, 1.0), cube_yaw=0.3):
    """The expert's actions [T, 7] and the observations it saw, episode key PRNGKey(seed)."""
    import jax

    init, act = _jit_expert("lift", style)
    st = init(jax.random.PRNGKey(seed))
    eef, yaw = np.array(start, np.float64), 0.0
    cube, held = np.array([0.0, 0.0, 0.83]), None
    acts, seen = [], []
    for _ in range(steps):
        o = obs(eef, yaw, cube, cube_yaw)
        a, st = act(o, st)
        a = np.asarray(a)
        acts.append(a), seen.append(o)
        eef = eef + 0.02 * a[:3]
        yaw += 0.1 * float(a[5])
        if a[6] > 0 and held is None and np.linalg.norm(eef - cube) < 0.02:
            held = cube - eef
        if a[6] <= 0:
            held = None
        if held is not None:
            cube = eef + held
    return np.stack(acts), seen
