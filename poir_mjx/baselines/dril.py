"""DRIL's reward (Brantley et al., 2020) from a trained BC ensemble: +1 where the ensemble agrees as well as it does on
the expert data, -1 elsewhere.

The BC ensemble is the project's (``poir_mjx.core.ensemble``: stacked members, vmap), trained by MSE on the expert data
with observations and actions standardised by the expert statistics. Two measures of disagreement ``d``:

- ``"max_pairwise"`` (default): the project's DRIL disagreement (``poir_mjx.core.rewards.dril_reward``),
  d = max_{i,j} ||pi_i(s') - pi_j(s')|| in standardised action units, scored on the state s' the action led to (as the
  POIR planner's default "next_state" timing: the action is judged by where it goes).
- ``"action_variance"``: DRIL's own continuous-action form, d = a^T Cov_i[pi_i(s)] a, the ensemble's variance along the
  (standardised) action a taken in s.

The threshold is the ``quantile`` (default 0.98, the DRIL code's default) of d over the expert transitions.
``clip="sign"`` is DRIL's clipped cost: r = +1 if d <= threshold else -1. ``clip="none"`` is the raw negative
disagreement in threshold units, r = -min(d / threshold, 10) (bounded below so a runaway state cannot dominate).
Non-finite disagreement (a diverged state) counts as the worst: -1, or -10.
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from poir_mjx.core import ensemble
from poir_mjx.core.config import MLPConfig, TrainConfig
from poir_mjx.core.normalizer import Normalizer
from poir_mjx.core.rewards import dril_reward
from poir_mjx.typed_config import ConfigError, check

RAW_FLOOR = 10.0  # the "none" reward is bounded below by -RAW_FLOOR


@dataclasses.dataclass(frozen=True)
class DrilConfig:
    ensemble_size: int = 27
    """BC networks in DRIL's ensemble (paper: 27)."""
    network: MLPConfig = MLPConfig(layers=5, width=256)
    """Each member's MLP (the paper does not say; the PPO policy's 5x256, relu)."""
    train: TrainConfig = TrainConfig(epochs=10)
    """Ensemble training: epochs over the expert data (paper: 10), batch 256, Adam lr 1e-4."""
    disagreement: Literal["max_pairwise", "action_variance"] = "max_pairwise"
    """How disagreement is measured (module docstring)."""
    quantile: float = 0.98
    """Quantile of the expert data's disagreement that separates +1 from -1 (DRIL's code: 0.98)."""
    clip: Literal["sign", "none"] = "sign"
    """"sign": DRIL's +1/-1 reward; "none": -min(d / threshold, 10)."""

    def cross_check(self, prefix: str) -> None:
        if not 0.0 < self.quantile <= 1.0:
            raise ConfigError(f"{prefix}quantile: must be in (0, 1], got {self.quantile}")
        if self.ensemble_size < 2:
            raise ConfigError(f"{prefix}ensemble_size: must be >= 2 (disagreement), got {self.ensemble_size}")


@struct.dataclass
class DrilReward:
    """Everything the reward needs, a pytree (goes into the learner's TrainState)."""

    params: object  # stacked ensemble params [K, ...]
    obs_norm: Normalizer
    act_norm: Normalizer
    threshold: jax.Array  # scalar: the expert quantile of the disagreement


def module(cfg: DrilConfig, act_size: int) -> ensemble.MLP:
    return ensemble.make_mlp(cfg.network, act_size)


def disagreement(cfg: DrilConfig, net: ensemble.MLP, rew: DrilReward, obs, action, next_obs) -> jax.Array:
    """d for a batch of transitions (raw observations [B, do], actions in [-1, 1] [B, da]) -> [B]."""
    if cfg.disagreement == "max_pairwise":
        preds = ensemble.apply_all(net, rew.params, rew.obs_norm(next_obs))  # [K, B, da]
        return -dril_reward(preds)
    preds = ensemble.apply_all(net, rew.params, rew.obs_norm(obs))
    a = rew.act_norm(action)
    proj = jnp.sum(preds * a[None], -1)  # [K, B]: each member's prediction along a
    return jnp.var(proj, axis=0, ddof=1) if preds.shape[0] > 1 else jnp.zeros(proj.shape[1:], proj.dtype)


def reward(cfg: DrilConfig, net: ensemble.MLP, rew: DrilReward, obs, action, next_obs) -> jax.Array:
    d = disagreement(cfg, net, rew, obs, action, next_obs)
    if cfg.clip == "sign":
        return jnp.where(d <= rew.threshold, 1.0, -1.0).astype(jnp.float32)  # NaN compares False: -1
    raw = -jnp.minimum(d / jnp.maximum(rew.threshold, 1e-12), RAW_FLOOR)
    return jnp.where(jnp.isfinite(raw), raw, -RAW_FLOOR).astype(jnp.float32)


def fit(cfg: DrilConfig, key: jax.Array, obs, actions, next_obs, verbose: bool = False) -> DrilReward:
    """Train the BC ensemble on (standardised obs -> standardised action), then set the threshold on the expert data."""
    check(cfg)
    obs, actions, next_obs = (np.asarray(x, np.float32) for x in (obs, actions, next_obs))
    obs_norm, act_norm = Normalizer.fit(obs), Normalizer.fit(actions)
    net = module(cfg, actions.shape[-1])
    k_init, k_train = jax.random.split(key)
    optimizer = ensemble.make_optimizer(cfg.train)
    init = jax.jit(lambda k: ensemble.init_train_state(ensemble.init_ensemble(net, k, cfg.ensemble_size, obs.shape[-1]),
                                                        optimizer))  # fmt: skip
    state = init(k_init)
    x, y = obs_norm(obs), act_norm(actions)
    batch = min(cfg.train.batch_size, obs.shape[0])
    for epoch, k in enumerate(jax.random.split(k_train, cfg.train.epochs)):
        state, losses = ensemble.train_epoch(net, optimizer, batch, state, x, y, k)
        if verbose:
            print(f"DRIL ensemble epoch {epoch + 1}/{cfg.train.epochs}: mse {float(losses.mean()):.4f}")
    rew = DrilReward(state.params, obs_norm, act_norm, jnp.zeros((), jnp.float32))
    return with_threshold(cfg, rew, obs, actions, next_obs)


def with_threshold(cfg: DrilConfig, rew: DrilReward, obs, actions, next_obs, chunk: int = 4096) -> DrilReward:
    """``rew`` with its threshold set to the ``cfg.quantile`` of d over the expert transitions (in chunks)."""
    net = module(cfg, np.shape(actions)[-1])
    fn = jax.jit(lambda r, o, a, o2: disagreement(cfg, net, r, o, a, o2))
    d = np.concatenate([np.asarray(fn(rew, obs[i:i + chunk], actions[i:i + chunk], next_obs[i:i + chunk]))
                        for i in range(0, np.shape(obs)[0], chunk)])  # fmt: skip
    return rew.replace(threshold=jnp.asarray(np.quantile(d, cfg.quantile), jnp.float32))
