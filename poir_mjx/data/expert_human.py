"""The scripted expert with an operator's variability: the ``human_like`` demo style.

A teleoperated demo differs from the scripted expert's in ways that matter to what a model learns from it: the
operator's hand wobbles in rotation, moves faster in one segment than the next, stops for a moment, comes in on
a curve, and now and then lets go and grasps again. This module wraps ``expert.act`` with all five, each drawn
per episode from the expert's own key, so the same key gives the same episode style in robosuite and inside a
vmapped MJX rollout (pure JAX, no Python branching on traced values):

- rotation jitter: a correlated (Ornstein-Uhlenbeck) wobble added to the three rotation actions, its size and
  correlation drawn per episode (the scripted expert's rotation is a fixed function of the observation);
- speed per segment: the position gain of each of the eight phases scaled by its own factor;
- pauses: on entering a phase, with some probability, the hand holds still for a few steps;
- approach path: in most episodes a lateral waypoint on the way to the first approach point;
- re-grasp: in some episodes, after the first close, the gripper opens (the hand still while it does) and the
  approach-descend-close repeats.

The base expert's draws are the scripted expert's for the same key (``expert.init(task, key)``); the operator's
come from ``fold_in(key, 1)``, so a human-like episode is its scripted twin with the variability on top.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct

from poir_mjx.data import expert as ex

PHASES = 8
SEGMENT_GAIN = (0.6, 1.5)  # range of each phase's speed factor
ROT_SIGMA = (0.02, 0.08)  # range of the rotation wobble's stationary std (action units)
ROT_RHO = (0.75, 0.95)  # range of its step-to-step correlation
PAUSE_P, PAUSE_STEPS = 0.25, (3, 12)  # chance of a pause on entering a phase; its length range
VIA_P, VIA_LATERAL, VIA_DZ = 0.7, (0.03, 0.08), (0.0, 0.06)  # waypoint chance, sideways offset (m), extra height
VIA_TOL, VIA_MAX_STEPS = 0.015, 60
REGRASP_P, REGRASP_OPEN_STEPS = 0.15, 8  # chance of a re-grasp; steps it holds still while the fingers open
PAUSE_TREMOR = 0.02  # std of the position actions while holding still
# Steps the human-like expert is given per episode (its pauses, detours and re-grasps take longer), capped at
# robosuite's horizon.
STEPS_FACTOR = 1.5


@struct.dataclass
class HumanState:
    base: ex.ExpertState
    rng: jax.Array
    seg_gain: jax.Array  # (8,) speed factor per phase
    rot_sigma: jax.Array
    rot_rho: jax.Array
    rot_noise: jax.Array  # (3,) the wobble's current value
    pause_len: jax.Array  # (8,) steps of the pause on entering each phase (0: none)
    hold: jax.Array  # steps of the current pause left
    via_on: jax.Array  # a waypoint still to reach
    via_set: jax.Array  # the waypoint has been placed (on the first step)
    via_lateral: jax.Array
    via_frac: jax.Array
    via_dz: jax.Array
    via_pos: jax.Array  # (3,)
    via_timer: jax.Array
    regrasp: jax.Array  # a re-grasp still to do
    prev_phase: jax.Array  # -1 before the first step


def init(task: ex.ExpertTask, rng: jax.Array) -> HumanState:
    """One episode's style: the scripted expert's draws for `rng`, then the operator's from fold_in(rng, 1)."""
    ks = jax.random.split(jax.random.fold_in(rng, 1), 11)
    u = lambda k, lo_hi, shape=(): jax.random.uniform(k, shape, minval=lo_hi[0], maxval=lo_hi[1])  # noqa: E731
    pause = jax.random.bernoulli(ks[4], PAUSE_P, (PHASES,))
    side = jnp.where(jax.random.bernoulli(ks[6], 0.5), 1.0, -1.0)
    return HumanState(
        base=ex.init(task, rng),
        rng=ks[0],
        seg_gain=u(ks[1], SEGMENT_GAIN, (PHASES,)),
        rot_sigma=u(ks[2], ROT_SIGMA),
        rot_rho=u(ks[3], ROT_RHO),
        rot_noise=jnp.zeros(3),
        pause_len=jnp.where(pause, jax.random.randint(ks[5], (PHASES,), *PAUSE_STEPS), 0),
        hold=jnp.zeros((), jnp.int32),
        via_on=jax.random.bernoulli(ks[7], VIA_P),
        via_set=jnp.zeros((), bool),
        via_lateral=side * u(ks[8], VIA_LATERAL),
        via_frac=u(ks[9], (0.3, 0.7)),
        via_dz=u(ks[10], VIA_DZ),
        via_pos=jnp.zeros(3),
        via_timer=jnp.zeros((), jnp.int32),
        regrasp=jax.random.bernoulli(jax.random.fold_in(ks[0], 1), REGRASP_P),
        prev_phase=-jnp.ones((), jnp.int32),
    )


def _waypoint(task: ex.ExpertTask, obs: dict, hs: HumanState) -> jax.Array:
    """A point part of the way from the hand to the first approach point, off to one side and a little higher."""
    eef = obs["robot0_eef_pos"]
    _, _, grasp = ex.object_pose(task, obs)
    goal = grasp + jnp.array([0.0, 0.0, hs.base.approach_h])
    d = goal[:2] - eef[:2]
    perp = jnp.array([-d[1], d[0]]) / jnp.maximum(jnp.linalg.norm(d), 1e-6)
    xy = eef[:2] + hs.via_frac * d + hs.via_lateral * perp
    return jnp.concatenate([xy, (eef[2] + hs.via_frac * (goal[2] - eef[2]) + hs.via_dz)[None]])


def act(task: ex.ExpertTask, obs: dict, hs: HumanState) -> tuple[jax.Array, HumanState]:
    """One human-like action (7,) in [-1, 1] and the next state."""
    st = hs.base
    p = st.phase
    rng, k_rot, k_pos = jax.random.split(hs.rng, 3)
    gain = st.gain * hs.seg_gain[p]
    a, nb = ex.act(task, obs, st.replace(gain=gain))
    nb = nb.replace(gain=st.gain)
    frozen = st.replace(rng=nb.rng)  # the phase machine waits; its noise stream moves on

    # Pauses: a phase's pause starts when the phase is entered (a re-grasp's wait for the fingers may be longer).
    hold = jnp.where(p != hs.prev_phase, jnp.maximum(hs.pause_len[p], hs.hold), hs.hold)
    pausing = hold > 0
    # The lateral waypoint, placed on the first step, is visited before the first approach point.
    via_pos = jnp.where(hs.via_set, hs.via_pos, _waypoint(task, obs, hs))
    eef = obs["robot0_eef_pos"]
    to_via = via_pos - eef
    via_done = (jnp.linalg.norm(to_via) < VIA_TOL) | (hs.via_timer >= VIA_MAX_STEPS)
    detour = hs.via_on & (p == 0) & jnp.logical_not(via_done) & jnp.logical_not(pausing)
    noise = jax.random.normal(k_pos, (3,))
    a_via = jnp.clip(gain * to_via / 0.05 + st.jitter * noise, -1.0, 1.0)
    a_pos = jnp.where(pausing, PAUSE_TREMOR * noise, jnp.where(detour, a_via, a[:3]))

    rot = hs.rot_rho * hs.rot_noise + jnp.sqrt(1 - hs.rot_rho**2) * hs.rot_sigma * jax.random.normal(k_rot, (3,))
    action = jnp.concatenate([a_pos, jnp.clip(a[3:6] + rot, -1.0, 1.0), a[6:]])

    nb = jax.tree_util.tree_map(lambda f, n: jnp.where(pausing | detour, f, n), frozen, nb)
    # Re-grasp: the first close, once done, opens again and goes back to the approach.
    again = hs.regrasp & (p == 2) & (nb.phase == 3)
    nb = nb.replace(phase=jnp.where(again, 0, nb.phase), timer=jnp.where(again, 0, nb.timer))
    hold = jnp.where(again, REGRASP_OPEN_STEPS, jnp.maximum(hold - 1, 0))  # open before moving away
    nxt = hs.replace(
        base=nb, rng=rng, rot_noise=rot, hold=hold, via_on=hs.via_on & jnp.logical_not(via_done),
        via_set=jnp.ones((), bool), via_pos=via_pos, via_timer=hs.via_timer + detour.astype(jnp.int32),
        regrasp=hs.regrasp & jnp.logical_not(again), prev_phase=p,
    )  # fmt: skip
    return action, nxt


def expert_fns(task: ex.ExpertTask, style: str):
    """(init(key), act(obs, state)) of the expert in `style` (expert.STYLES)."""
    if style == "scripted":
        return (lambda rng: ex.init(task, rng)), (lambda obs, st: ex.act(task, obs, st))
    if style == "human_like":
        return (lambda rng: init(task, rng)), (lambda obs, st: act(task, obs, st))
    raise ValueError(f"demo style: expected one of {', '.join(ex.STYLES)}, got {style!r}")


def expert_steps(base_steps: int, style: str, horizon: int) -> int:
    """The steps an episode of `style` is given: the scripted expert's, or STEPS_FACTOR times as many (capped)."""
    return base_steps if style == "scripted" else min(int(base_steps * STEPS_FACTOR), horizon)
