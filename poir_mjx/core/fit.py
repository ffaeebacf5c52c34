"""Offline training of POIR's ensembles on expert transitions (``POIR.fit``): normalisers, the BC heads in the
chosen space, the world models on normalised deltas, the L2 reward's expert states and the disagreement levels."""

from __future__ import annotations

from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.core import ensemble as ens
from poir_mjx.core import rewards
from poir_mjx.core.config import ConfigError
from poir_mjx.core.normalizer import Normalizer, observation_floor
from poir_mjx.core.params import POIRParams, TrainingDivergedError


def fit(
    agent,
    key: jax.Array,
    obs: np.ndarray,
    act: np.ndarray,
    next_obs: np.ndarray,
    *,
    obs_groups: tuple[str, ...] | None = None,
    train_world_model: bool = True,
    epochs: int | None = None,
    callback: Callable[[str, int, np.ndarray], None] | None = None,
    bc_params=None,
) -> tuple[POIRParams, dict]:
    """Train the BC (and world-model) ensembles on expert transitions. Returns params and loss history.

    obs_groups: each observation dimension's group ("position", "quaternion", "gripper"; see
    ``poir_mjx.envs.layout.obs_groups``), which sets its std floor; None: no observation floor.
    bc_params: with bc_space "raw" only, the BC heads of the policy agent fitted with the same key, config and
    data, used instead of training them again (training would give them bit for bit: the raw space is the
    policy's own).
    """
    cfg = agent.config
    if bc_params is not None and cfg.bc_space != "raw":
        raise ValueError(f"bc_params: only a raw-space prior can reuse the policy's heads, not {cfg.bc_space!r}")
    obs, act, next_obs = (jnp.asarray(a, jnp.float32) for a in (obs, act, next_obs))
    if obs.shape[-1] != agent.obs_size or next_obs.shape != obs.shape:
        raise ValueError(f"obs: expected [n, {agent.obs_size}] and next_obs of the same shape, got {obs.shape}, {next_obs.shape}")
    if act.shape != (obs.shape[0], agent.act_size):
        raise ValueError(f"act: expected shape ({obs.shape[0]}, {agent.act_size}), got {act.shape}")
    if obs.shape[0] < cfg.train.batch_size:  # before any epoch: one line, not a failure inside the first
        raise ConfigError(f"train.batch_size: {cfg.train.batch_size} exceeds the {obs.shape[0]} expert transitions")
    nc = cfg.normalizer
    obs_norm = Normalizer.fit(obs, cfg.normalize, observation_floor(nc, obs_groups, agent.obs_size))
    act_norm = Normalizer.fit(act, cfg.normalize, nc.action_std_floor)
    s, a = agent._clip(obs_norm(obs)), act_norm(act)
    s2 = agent._clip(obs_norm(next_obs))
    k_bc, k_wm, k_loop = jax.random.split(key, 3)
    opt = ens.make_optimizer(cfg.train)
    epochs = cfg.train.epochs if epochs is None else epochs
    history = {"bc": [], "wm": []}

    def run(name, module, k_init, x, y, weights=None):
        st = ens.init_train_state(ens.init_ensemble(module, k_init, cfg.ensemble_size, x.shape[-1]), opt)
        for e in range(epochs):
            st, loss = ens.train_epoch(module, opt, cfg.train.batch_size, st, x, y, jax.random.fold_in(k_loop, e),
                                       weights)  # fmt: skip
            history[name].append(np.asarray(loss))
            if not np.all(np.isfinite(history[name][-1])):  # stop: nothing trained on NaN is saved or evaluated
                raise TrainingDivergedError(
                    f"train: the {name} ensemble's loss is {history[name][-1].tolist()} at epoch {e + 1} of "
                    f"{epochs}: training diverged (field 'train.learning_rate' is {cfg.train.learning_rate}); "
                    "nothing was recorded")  # fmt: skip
            if callback is not None:
                callback(name, e, np.asarray(loss))
        return st.params

    if bc_params is not None:
        bc = bc_params
    elif cfg.bc_space == "raw":
        bc = run("bc", agent.train_modules[0], k_bc, obs, act)
    else:
        weights = act_norm.std**2 if cfg.bc_space == "weighted" else None
        bc = run("bc", agent.train_modules[0], k_bc, s, a, weights)
    wm = run("wm", agent.train_modules[1], k_wm, jnp.concatenate([s, a], -1), s2 - s) if train_world_model else None
    expert = s
    if cfg.planner.l2_approx_size:
        expert = rewards.approximate_subset(s, cfg.planner.l2_approx_size, jax.random.fold_in(key, 7))
    zero = jnp.zeros((), jnp.float32)
    params = POIRParams(bc=bc, wm=wm, reward_wm=wm, obs_norm=obs_norm, act_norm=act_norm, expert_states=expert,
                        dril_level=zero, morel_level=zero)  # fmt: skip
    params = params.replace(**agent.disagreement_levels(params, s, a))
    return params, {k: np.array(v) for k, v in history.items()}
