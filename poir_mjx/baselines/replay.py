"""A fixed-capacity replay of transitions on the device, time-major per environment, with n-step windows.

Layout: ``[rows, envs, ...]``; one ``add`` writes one row (one step of every vectorised environment) at ``ptr`` and
the oldest row is overwritten once full. Keeping each environment's transitions in time order lets n-step returns be
computed at sample time (``sample_windows`` + ``nstep_return``) with rewards that the method computes then (SQIL's
constants, DAC's current discriminator), instead of freezing rewards at insertion.

A window is the up-to-n consecutive transitions of one environment from a sampled start. Step k belongs to it
(``live``) when step k-1 belongs to it and did not end its episode (``end``: truncation, termination or an invalid
row), step k is a valid row, and step k was already written (a window never runs past the newest row). The n-step
target then bootstraps from the next observation of the window's last live step, with discount gamma^m (m live steps),
or 0 when that step is a true termination (``terminal``; only expert demonstrations have them here).

Expert transitions use the same store with one "environment" (``from_expert``): rows in their given order, a
demonstration continuing to the next row unless the row ends it or the next row does not start where it ended.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct


@struct.dataclass
class Replay:
    obs: jax.Array  # [T, E, do]
    act: jax.Array  # [T, E, da]
    next_obs: jax.Array  # [T, E, do]
    end: jax.Array  # [T, E] bool: the episode ended after this transition (truncated, terminated or invalid)
    terminal: jax.Array  # [T, E] bool: a true termination (no bootstrap; DAC's absorbing state)
    valid: jax.Array  # [T, E] bool: a real transition (False for diverged physics and unwritten rows)
    size: jax.Array  # int32: rows written (<= T)
    ptr: jax.Array  # int32: the next row written

    @property
    def rows(self) -> int:
        return self.obs.shape[0]

    @property
    def num_envs(self) -> int:
        return self.obs.shape[1]


@struct.dataclass
class Window:
    """n consecutive transitions from B sampled starts: leaves [B, n, ...]; ``weight`` [B] is 0 for an invalid start."""

    obs: jax.Array
    act: jax.Array
    next_obs: jax.Array
    live: jax.Array  # [B, n] bool, a prefix of each row
    terminal: jax.Array  # [B, n] bool
    weight: jax.Array  # [B] float32

    def first(self) -> tuple[jax.Array, jax.Array, jax.Array]:
        """The 1-step transitions (obs, act, next_obs) at the sampled starts, [B, ...]."""
        return self.obs[:, 0], self.act[:, 0], self.next_obs[:, 0]


def init(capacity: int, num_envs: int, obs_size: int, act_size: int) -> Replay:
    """An empty store of ``capacity`` transitions (rounded down to whole rows of ``num_envs``)."""
    rows = capacity // num_envs
    if rows < 1:
        raise ValueError(f"replay_capacity: {capacity} holds not one row of {num_envs} environments")
    z = lambda *s: jnp.zeros((rows, num_envs) + s, jnp.float32)  # noqa: E731
    f = jnp.zeros((rows, num_envs), bool)
    return Replay(obs=z(obs_size), act=z(act_size), next_obs=z(obs_size), end=f, terminal=f, valid=f,
                  size=jnp.zeros((), jnp.int32), ptr=jnp.zeros((), jnp.int32))  # fmt: skip


def add(buf: Replay, obs, act, next_obs, end, valid, terminal=None) -> Replay:
    """Write one row: a transition of each environment ([E, ...]); invalid ones are stored as zeros."""
    terminal = jnp.zeros_like(end) if terminal is None else terminal
    keep = lambda x: jnp.where(valid.reshape((-1,) + (1,) * (x.ndim - 1)), x, 0).astype(jnp.float32)  # noqa: E731
    i = buf.ptr
    return buf.replace(
        obs=buf.obs.at[i].set(keep(obs)),
        act=buf.act.at[i].set(keep(act)),
        next_obs=buf.next_obs.at[i].set(keep(next_obs)),
        end=buf.end.at[i].set(end | ~valid),
        terminal=buf.terminal.at[i].set(terminal & valid),
        valid=buf.valid.at[i].set(valid),
        size=jnp.minimum(buf.size + 1, buf.rows).astype(jnp.int32),
        ptr=((i + 1) % buf.rows).astype(jnp.int32),
    )


def from_expert(obs, act, next_obs, demo_end, terminal=None) -> Replay:
    """The expert transitions as a full store of one environment. A demonstration continues to the next row unless
    the row ends it (``demo_end``) or the next row does not start where it ended; ``terminal`` (default: none)
    marks the ends that are true terminations (no bootstrap)."""
    obs, act, next_obs = (np.asarray(x, np.float32) for x in (obs, act, next_obs))
    demo_end = np.asarray(demo_end, bool)
    terminal = np.zeros_like(demo_end) if terminal is None else np.asarray(terminal, bool) & demo_end
    n = obs.shape[0]
    if n == 0:
        raise ValueError("expert data: no transitions")
    continues = np.zeros(n, bool)
    continues[:-1] = ~demo_end[:-1] & np.all(np.isclose(next_obs[:-1], obs[1:], rtol=1e-5, atol=1e-6), axis=-1)
    col = lambda x: jnp.asarray(x)[:, None]  # noqa: E731
    return Replay(obs=col(obs), act=col(act), next_obs=col(next_obs), end=col(~continues), terminal=col(terminal),
                  valid=col(np.ones(n, bool)), size=jnp.asarray(n, jnp.int32), ptr=jnp.zeros((), jnp.int32))


def sample_windows(buf: Replay, key: jax.Array, batch: int, n: int) -> Window:
    """B uniform starts among the written rows and all environments, each with its window of up to n steps."""
    k_t, k_e = jax.random.split(key)
    t = jax.random.randint(k_t, (batch,), 0, jnp.maximum(buf.size, 1))
    e = jax.random.randint(k_e, (batch,), 0, buf.num_envs)
    # rows from t up to the newest (ptr - 1), t included; ptr == 0 with a full store: all of them
    avail = (buf.ptr - t - 1) % buf.rows + 1
    ks = jnp.arange(n)
    rows = (t[:, None] + ks) % buf.rows  # [B, n]
    cols = jnp.broadcast_to(e[:, None], rows.shape)
    valid, end = buf.valid[rows, cols], buf.end[rows, cols]
    prev_ok = jnp.concatenate([jnp.ones((batch, 1), bool), ~end[:, :-1]], axis=1)
    live = jnp.cumprod(prev_ok & valid & (ks < avail[:, None]), axis=1).astype(bool)
    return Window(obs=buf.obs[rows, cols], act=buf.act[rows, cols], next_obs=buf.next_obs[rows, cols], live=live,
                  terminal=buf.terminal[rows, cols] & live, weight=live[:, 0].astype(jnp.float32))  # fmt: skip


def nstep_return(rewards: jax.Array, live: jax.Array, terminal: jax.Array, gamma: float):
    """Rewards, live, terminal [B, n] -> (sum_k gamma^k r_k over the live steps [B], bootstrap discount [B],
    index of the last live step [B]): target = return + discount * V(next_obs[last])."""
    n = rewards.shape[1]
    powers = gamma ** jnp.arange(n, dtype=jnp.float32)
    ret = jnp.sum(jnp.where(live, rewards, 0.0) * powers, axis=1)
    m = jnp.maximum(live.sum(1), 1)
    last = m - 1
    term = jnp.take_along_axis(terminal, last[:, None], axis=1)[:, 0]
    return ret, jnp.where(term, 0.0, gamma**m.astype(jnp.float32)), last


def at_last(x: jax.Array, last: jax.Array) -> jax.Array:
    """x [B, n, ...] at each row's index ``last`` [B] -> [B, ...]."""
    return jnp.take_along_axis(x, last.reshape((-1, 1) + (1,) * (x.ndim - 2)), axis=1)[:, 0]
