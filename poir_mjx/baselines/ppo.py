"""PPO as one compiled training phase: ``train(state, iterations)`` is ``lax.scan`` over iterations, each an unroll of
``unroll_length`` steps of ``num_envs`` vmapped environments followed by ``epochs`` x ``minibatches`` updates.

The reward is a function the caller supplies, ``reward_fn(reward_params, obs, action, next_obs) -> [num_envs]`` (raw
observation vectors, ``next_obs`` non-finite where the physics diverged; the clipped action the environment received),
so the same PPO trains on DRIL's reward (``ppo_dril.py``) or on a task's true reward (the tests' sanity check).
Networks, losses and the action distribution: ``ppo_losses.py``; vectorised environments with auto-reset:
``ppo_env.py``.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any, Callable, Literal

import jax
import jax.numpy as jnp
import optax
from flax import struct

from poir_mjx.baselines import ppo_env
from poir_mjx.baselines.ppo_losses import Batch, LossConfig, PolicyNet, ValueNet, gae, log_prob, loss
from poir_mjx.core.normalizer import Normalizer
from poir_mjx.rollout.protocol import Env

RewardFn = Callable[[Any, jax.Array, jax.Array, jax.Array], jax.Array]


@dataclasses.dataclass(frozen=True)
class PPOConfig:
    layers: int = 5
    """Dense layers of the policy and of the value network, the output layer included (paper: policy 5x256)."""
    width: int = 256
    """Hidden units per hidden layer (paper: 256)."""
    activation: Literal["relu", "tanh", "gelu"] = "tanh"
    """Hidden activation (the paper does not say; tanh is the usual PPO choice)."""
    learning_rate: float = 1e-4
    """Adam learning rate, policy and value alike (paper: 1e-4)."""
    epochs: int = 2
    """Passes over each unroll's data (paper: 2)."""
    minibatches: int = 8
    """Minibatches per pass; unroll_length x num_envs must be a multiple (paper: 8)."""
    unroll_length: int = 8
    """Environment steps per environment between updates (paper: 8)."""
    value_coef: float = 1.0
    """Weight of the value loss, 0.5 x MSE (paper: 1)."""
    discount: float = 0.99
    """Discount factor (not stated in the paper; DRIL's code uses 0.99)."""
    gae_lambda: float = 0.95
    """GAE lambda (not stated; the usual 0.95)."""
    clip_epsilon: float = 0.2
    """PPO ratio clipping (not stated; the usual 0.2)."""
    entropy_coef: float = 0.0
    """Weight of the entropy bonus (not stated; our choice)."""
    max_grad_norm: float = 0.5
    """Gradient norm clip, applied to the policy's and the value network's gradients separately (not stated)."""
    init_std: float = 1.0
    """Initial std of the Gaussian policy, before the clip to [-1, 1] (DRIL's PPO code starts at 1)."""
    obs_clip: float = 10.0
    """Observations standardised with the expert data's statistics are clipped to [-obs_clip, obs_clip]."""
    obs_std_floor: float = 1e-3
    """Smallest std of an observation dimension in the standardisation (environment units)."""
    bc_coef: float = 0.0
    """Weight of the BC loss on expert data in each policy update (DRIL's term; 0: plain PPO)."""
    bc_batch_size: int = 256
    """Expert transitions per minibatch for the BC loss (drawn with replacement)."""


@struct.dataclass
class PPOState:
    params: Any  # {"policy": ..., "value": ...}
    opt_state: Any  # {"policy": ..., "value": ...}
    env_state: Any  # num_envs environment states
    env_params: Any  # num_envs copies of the noise levels
    obs_norm: Normalizer  # expert-data statistics
    expert_obs: jax.Array  # [N, obs_size] normalised expert observations (BC loss)
    expert_act: jax.Array  # [N, act_size]
    reward_params: Any  # what reward_fn needs (e.g. DRIL's ensemble)
    key: jax.Array
    env_steps: jax.Array  # int32 scalar


class PPO:
    def __init__(self, env: Env, cfg: PPOConfig, num_envs: int, episode_steps: int, act_size: int,
                 reward_fn: RewardFn):  # fmt: skip
        if (cfg.unroll_length * num_envs) % cfg.minibatches:
            raise ValueError(f"minibatches: {cfg.minibatches} does not divide unroll_length x num_envs "
                             f"= {cfg.unroll_length * num_envs}")  # fmt: skip
        self.env, self.cfg, self.num_envs, self.episode_steps = env, cfg, num_envs, episode_steps
        self.reward_fn = reward_fn
        self.policy = PolicyNet(act_size, cfg.layers, cfg.width, cfg.activation, cfg.init_std)
        self.value = ValueNet(cfg.layers, cfg.width, cfg.activation)
        self.optimizer = optax.chain(optax.clip_by_global_norm(cfg.max_grad_norm),
                                     optax.adam(cfg.learning_rate, eps=1e-5))  # fmt: skip
        self.loss_cfg = LossConfig(cfg.clip_epsilon, cfg.value_coef, cfg.entropy_coef, cfg.bc_coef)
        self.train = jax.jit(self._train, static_argnums=1)
        self._act = self._make_policy_fn()

    @property
    def steps_per_iteration(self) -> int:
        return self.cfg.unroll_length * self.num_envs

    def init(self, key, expert_obs, expert_act, env_params, reward_params) -> PPOState:
        """Fresh networks and optimisers, ``num_envs`` reset environments (one compiled call)."""
        obs_norm = Normalizer.fit(expert_obs, floor=self.cfg.obs_std_floor)
        env_params = ppo_env.broadcast_params(env_params, self.num_envs)
        return jax.jit(self._init)(key, obs_norm, jnp.asarray(expert_obs, jnp.float32),
                                   jnp.asarray(expert_act, jnp.float32), env_params, reward_params)  # fmt: skip

    def _init(self, key, obs_norm, expert_obs, expert_act, env_params, reward_params) -> PPOState:
        k_pi, k_v, k_env, key = jax.random.split(key, 4)
        dummy = jnp.zeros((1, expert_obs.shape[-1]), jnp.float32)
        params = {"policy": self.policy.init(k_pi, dummy), "value": self.value.init(k_v, dummy)}
        opt_state = {name: self.optimizer.init(p) for name, p in params.items()}
        return PPOState(params=params, opt_state=opt_state, env_state=ppo_env.reset(self.env, k_env, env_params),
                        env_params=env_params, obs_norm=obs_norm, expert_obs=self.normalise(obs_norm, expert_obs),
                        expert_act=expert_act, reward_params=reward_params, key=key,
                        env_steps=jnp.zeros((), jnp.int32))  # fmt: skip

    def normalise(self, obs_norm: Normalizer, obs):
        return jnp.clip(obs_norm(obs), -self.cfg.obs_clip, self.cfg.obs_clip)

    def policy_fn(self):
        """(params, obs_vector, key) -> clip(mu(s), -1, 1): the deterministic policy; params = (policy, obs_norm).
        The same function object on every call (so callers' jit caches hit)."""
        return self._act

    def _make_policy_fn(self):

        def act(params, obs, key):
            policy_params, obs_norm = params
            mean, _ = self.policy.apply(policy_params, self.normalise(obs_norm, obs))
            return jnp.clip(mean, -1.0, 1.0)

        return act

    # --- one iteration: unroll, then updates ---------------------------------------------------------------------

    def _unroll(self, state: PPOState, key):
        def env_step(env_state, k):
            k_act, k_reset = jax.random.split(k)
            obs = ppo_env.observe(self.env, env_state)
            obs_n = self.normalise(state.obs_norm, obs)
            mean, log_std = self.policy.apply(state.params["policy"], obs_n)
            noise = jax.vmap(lambda kk: jax.random.normal(kk, mean.shape[1:]))(jax.random.split(k_act, self.num_envs))
            action = mean + jnp.exp(log_std) * noise
            clipped = jnp.clip(action, -1.0, 1.0)
            env_state, out = ppo_env.step(self.env, self.episode_steps, env_state, state.env_params, clipped, k_reset)
            reward = self.reward_fn(state.reward_params, obs, clipped, out.next_obs)
            # the reward sees a diverged state as it is (DRIL scores it as the worst); the value net sees zeros
            next_obs_n = self.normalise(state.obs_norm, jnp.where(jnp.isfinite(out.next_obs), out.next_obs, 0.0))
            step = (obs_n, action, log_prob(mean, log_std, action), reward, next_obs_n, out.ended, out.diverged,
                    out.success)  # fmt: skip
            return env_state, step

        keys = jax.random.split(key, self.cfg.unroll_length)
        return jax.lax.scan(env_step, state.env_state, keys)

    def _update(self, params, opt_state, batch: Batch, expert_idx, expert_obs, expert_act):
        grad_fn = jax.grad(functools.partial(loss, self.policy, self.value, self.loss_cfg), has_aux=True)
        grads, metrics = grad_fn(params, batch, expert_obs[expert_idx], expert_act[expert_idx])
        new_params, new_opt = {}, {}
        for name in params:  # each network has its own gradient clip and Adam state
            upd, new_opt[name] = self.optimizer.update(grads[name], opt_state[name], params[name])
            new_params[name] = optax.apply_updates(params[name], upd)
        return new_params, new_opt, metrics

    def _iteration(self, state: PPOState, _):
        cfg = self.cfg
        key, k_unroll, k_perm, k_bc = jax.random.split(state.key, 4)
        env_state, (obs_n, action, logp, reward, next_obs_n, ended, diverged, success) = self._unroll(state, k_unroll)
        values = self.value.apply(state.params["value"], obs_n)
        next_values = self.value.apply(state.params["value"], next_obs_n)
        adv, target = gae(reward, values, next_values, ended.astype(jnp.float32), diverged.astype(jnp.float32),
                          cfg.discount, cfg.gae_lambda)  # fmt: skip
        flat = jax.tree_util.tree_map(lambda x: x.reshape((-1,) + x.shape[2:]),
                                      Batch(obs_n, action, logp, adv, target))  # fmt: skip
        n = flat.obs.shape[0]
        mb = n // cfg.minibatches
        perms = jax.vmap(lambda k: jax.random.permutation(k, n))(jax.random.split(k_perm, cfg.epochs))
        perms = perms.reshape(cfg.epochs * cfg.minibatches, mb)
        n_expert = state.expert_obs.shape[0]
        expert_idx = jax.random.randint(k_bc, (perms.shape[0], cfg.bc_batch_size), 0, n_expert)

        def body(carry, xs):
            params, opt_state = carry
            idx, e_idx = xs
            batch = jax.tree_util.tree_map(lambda x: x[idx], flat)
            params, opt_state, metrics = self._update(params, opt_state, batch, e_idx, state.expert_obs,
                                                      state.expert_act)  # fmt: skip
            return (params, opt_state), metrics

        (params, opt_state), metrics = jax.lax.scan(body, (state.params, state.opt_state), (perms, expert_idx))
        finished = ended.sum()
        metrics = {k: v.mean() for k, v in metrics.items()}
        metrics.update(imitation_reward=reward.mean(), episodes_finished=finished,
                       episode_success=jnp.where(finished > 0, success.sum() / jnp.maximum(finished, 1), jnp.nan))
        state = state.replace(params=params, opt_state=opt_state, env_state=env_state, key=key,
                              env_steps=state.env_steps + self.steps_per_iteration)  # fmt: skip
        return state, metrics

    def _train(self, state: PPOState, iterations: int):
        return jax.lax.scan(self._iteration, state, None, length=iterations)
