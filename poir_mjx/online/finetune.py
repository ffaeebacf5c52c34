"""World-model fine-tuning on a mixture of expert (offline) and deployment (online) transitions.

The online fraction of each batch follows the paper's schedule: ``mix_start``, plus
``mix_increment`` every ``mix_every`` gradient steps, capped at ``mix_max``. Online transitions
are normalised with the offline statistics. The BC prior is not touched. Many gradient steps are
one compiled function (``lax.scan`` over steps, ``vmap`` over ensemble members).
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

from poir_mjx.core import ensemble as ens
from poir_mjx.core.config import OnlineConfig
from poir_mjx.core.normalizer import Normalizer
from poir_mjx.online.buffer import ReplayBuffer


def online_fraction(cfg: OnlineConfig, grad_step) -> jax.Array:
    """Fraction of online transitions in the batch at (global) gradient step `grad_step`."""
    frac = cfg.mix_start + cfg.mix_increment * (jnp.asarray(grad_step) // cfg.mix_every)
    return jnp.minimum(frac, cfg.mix_max)


def world_model_targets(obs_norm: Normalizer, act_norm: Normalizer, obs, act, next_obs, clip: float = 0.0):
    """(inputs [s, a], target s' - s) in normalised units, as the world model is trained offline
    (normalised states clipped to [-clip, clip] when clip > 0, as ``POIR.normalize_obs`` does)."""
    s, s2 = obs_norm(obs), obs_norm(next_obs)
    if clip > 0:
        s, s2 = jnp.clip(s, -clip, clip), jnp.clip(s2, -clip, clip)
    return jnp.concatenate([s, act_norm(act)], -1), s2 - s


@functools.partial(jax.jit, static_argnames=("module", "clip"))
def deployment_error(module, wm_params, obs_norm, act_norm, obs, act, next_obs, valid, clip: float = 0.0) -> jax.Array:
    """Per-member one-step error (summed squared, normalised units) averaged over the valid transitions."""
    x, y = world_model_targets(obs_norm, act_norm, obs, act, next_obs, clip)
    pred = ens.apply_all(module, wm_params, x)
    err = jnp.sum((pred - y) ** 2, -1)
    w = valid.astype(err.dtype)
    return jnp.sum(err * w, -1) / jnp.maximum(w.sum(), 1.0)


@functools.partial(jax.jit, static_argnames=("module", "optimizer", "cfg", "batch_size", "num_steps", "clip"))
def finetune(module, optimizer, cfg: OnlineConfig, batch_size: int, num_steps: int, state: ens.TrainState,
             offline_x, offline_y, buf: ReplayBuffer, obs_norm, act_norm, grad_step0, key, clip: float = 0.0):  # fmt: skip
    """`num_steps` gradient steps on the mixture; returns (state, mean loss per step [num_steps, K], last fraction)."""
    k = ens.ensemble_size(state.params)
    on_x, on_y = world_model_targets(obs_norm, act_norm, buf.obs, buf.act, buf.next_obs, clip)
    on_x, on_y = on_x.astype(offline_x.dtype), on_y.astype(offline_y.dtype)
    n_off = offline_x.shape[0]
    n_on = jnp.maximum(buf.size, 1)

    def loss_fn(p, x, y, w):
        err = jnp.sum((module.apply(p, x) - y) ** 2, -1)
        return jnp.sum(err * w) / jnp.maximum(jnp.sum(w), 1.0)

    def member_step(p, o, kk, n_online):
        k_off, k_on = jax.random.split(kk)
        off = jax.random.randint(k_off, (batch_size,), 0, n_off)
        on = jax.random.randint(k_on, (batch_size,), 0, n_on)
        use_on = jnp.arange(batch_size) < n_online
        x = jnp.where(use_on[:, None], on_x[on], offline_x[off])
        y = jnp.where(use_on[:, None], on_y[on], offline_y[off])
        w = jnp.where(use_on, buf.valid[on], 1.0).astype(x.dtype)
        return ens.member_update(optimizer, loss_fn, p, o, x, y, w)

    def body(carry, i):
        p, o = carry
        frac = jnp.where(buf.size > 0, online_fraction(cfg, grad_step0 + i), 0.0)
        n_online = jnp.round(frac * batch_size).astype(jnp.int32)
        keys = jax.random.split(jax.random.fold_in(key, i), k)
        p, o, loss = jax.vmap(member_step, in_axes=(0, 0, 0, None))(p, o, keys, n_online)
        return (p, o), (loss, frac)

    (p, o), (losses, fracs) = jax.lax.scan(body, (state.params, state.opt_state), jnp.arange(num_steps))
    return ens.TrainState(p, o), losses, fracs[-1]
