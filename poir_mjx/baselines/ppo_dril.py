"""PPO+DRIL, the paper's on-policy baseline: PPO on DRIL's disagreement reward, plus DRIL's BC loss on expert data.

``init`` trains DRIL's BC ensemble on the expert data (``dril.py``, the project's ensemble code), sets the reward's
threshold, then builds PPO (``ppo.py``) with ``num_envs`` environments. One ``train`` iteration is one PPO unroll
(``unroll_length`` steps of every environment, ``env_steps_per_iteration`` steps in all) and its updates.
The paper's settings: policy 5x256, lr 1e-4, 2 epochs, 8 minibatches, unroll 8, value coef 1; DRIL ensemble of 27,
10 epochs. What the paper leaves out is our choice and says so in the field's comment.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optax

from poir_mjx.baselines import dril
from poir_mjx.baselines.dril import DrilConfig
from poir_mjx.baselines.learner import ExpertData
from poir_mjx.baselines.ppo import PPO, PPOConfig, PPOState
from poir_mjx.core.config import MLPConfig, TrainConfig
from poir_mjx.rollout.protocol import Env
from poir_mjx.typed_config import ConfigError, check


@dataclasses.dataclass(frozen=True)
class Config:
    ppo: PPOConfig = PPOConfig(bc_coef=1.0)
    """PPO's settings (paper: 5x256, lr 1e-4, 2 epochs, 8 minibatches, unroll 8, value coef 1), BC loss weight 1."""
    dril: DrilConfig = DrilConfig()
    """DRIL's ensemble and reward (paper: 27 networks, 10 epochs; clipped +1/-1 at the expert 0.98 quantile)."""
    num_envs: int = 256
    """Environments stepped in parallel (the paper does not say; our choice)."""
    episode_steps: int = 400
    """Training episodes are truncated (bootstrapped, not terminated) after this many steps (the sweep's max_steps)."""
    total_env_steps: int = 500_000
    """Environment steps of a run, all environments together (paper: 500k)."""
    eval_every: int = 50_000
    """Evaluate the deterministic policy every so many environment steps (paper: 50k)."""
    bc_init_epochs: int = 0
    """If > 0, the policy mean is first fitted by BC for this many epochs over the expert data (DRIL's code starts
    from its BC policy; the paper does not say, 0 starts PPO from scratch)."""

    ZERO_OK = ("bc_init_epochs",)

    def validate(self) -> Config:
        """Raise a ConfigError naming the field of the first bad value; return self."""
        return check(self)

    def cross_check(self, prefix: str) -> None:
        if (self.ppo.unroll_length * self.num_envs) % self.ppo.minibatches:
            raise ConfigError(f"{prefix}ppo.minibatches: {self.ppo.minibatches} does not divide unroll_length x "
                              "num_envs")  # fmt: skip


PRESETS = {
    "paper": Config(),
    # CPU-sized: small networks, an ensemble of 5, few environments; a smoke-test scale, not the paper's.
    "cpu-small": Config(
        ppo=PPOConfig(layers=3, width=64, bc_coef=1.0, bc_batch_size=64),
        dril=DrilConfig(ensemble_size=5, network=MLPConfig(layers=3, width=64),
                        train=TrainConfig(epochs=50, batch_size=64, learning_rate=1e-3)),
        num_envs=16, total_env_steps=50_000, eval_every=10_000,
    ),  # fmt: skip
}


class PPODRIL:
    """The Learner (``poir_mjx.baselines.learner``) of PPO+DRIL on one environment."""

    name = "ppo_dril"

    def __init__(self, env: Env, cfg: Config, verbose: bool = False):
        self.env, self.cfg, self.verbose = env, cfg.validate(), verbose
        self._ppo: PPO | None = None
        self._net = None

    @property
    def env_steps_per_iteration(self) -> int:
        """Environment steps one ``train`` iteration takes (an unroll of every environment)."""
        return self.cfg.ppo.unroll_length * self.cfg.num_envs

    def _build(self, act_size: int) -> PPO:
        if self._ppo is None:
            self._net = dril.module(self.cfg.dril, act_size)
            dcfg, net = self.cfg.dril, self._net

            def reward_fn(rew, obs, action, next_obs):
                return dril.reward(dcfg, net, rew, obs, action, next_obs)

            self._ppo = PPO(self.env, self.cfg.ppo, self.cfg.num_envs, self.cfg.episode_steps, act_size, reward_fn)
        return self._ppo

    @property
    def ppo(self) -> PPO:
        if self._ppo is None:
            raise RuntimeError("PPODRIL: call init() first (the action size comes from the expert data)")
        return self._ppo

    def init(self, key: jax.Array, expert: ExpertData, env_params: Any) -> PPOState:
        k_dril, k_ppo, k_bc = jax.random.split(key, 3)
        ppo = self._build(expert.actions.shape[-1])
        rew = dril.fit(self.cfg.dril, k_dril, expert.obs, expert.actions, expert.next_obs, self.verbose)
        state = ppo.init(k_ppo, expert.obs, expert.actions, env_params, rew)
        if self.cfg.bc_init_epochs:
            state = state.replace(params=dict(state.params, policy=self._bc_init(state, k_bc)))
        return state

    def _bc_init(self, state: PPOState, key):
        """The policy mean fitted by MSE to the expert actions (Adam at PPO's learning rate, minibatches of
        bc_batch_size), before PPO starts."""
        ppo, cfg = self.ppo, self.cfg.ppo
        n = state.expert_obs.shape[0]
        batch = min(cfg.bc_batch_size, n)
        steps = n // batch
        opt = optax.adam(cfg.learning_rate)

        def loss(p, idx):
            mean, _ = ppo.policy.apply(p, state.expert_obs[idx])
            return jnp.mean(jnp.sum((mean - state.expert_act[idx]) ** 2, -1))

        def step(carry, idx):
            p, o = carry
            g = jax.grad(loss)(p, idx)
            upd, o = opt.update(g, o, p)
            return (optax.apply_updates(p, upd), o), None

        @jax.jit
        def run(p, key):
            perms = jax.vmap(lambda k: jax.random.permutation(k, n)[: steps * batch])(
                jax.random.split(key, self.cfg.bc_init_epochs))
            (p, _), _ = jax.lax.scan(step, (p, opt.init(p)), perms.reshape(-1, batch))
            return p

        return run(state.params["policy"], key)

    def train(self, state: PPOState, iterations: int) -> tuple[PPOState, dict[str, jax.Array]]:
        return self.ppo.train(state, iterations)

    def env_steps(self, state: PPOState) -> jax.Array:
        return state.env_steps

    def policy_params(self, state: PPOState):
        return (state.params["policy"], state.obs_norm)

    def policy_fn(self):
        return self.ppo.policy_fn()

    def reward(self, state: PPOState, obs, action, next_obs) -> np.ndarray:
        """DRIL's reward on a batch of raw transitions (for reports and tests); after ``init``."""
        if self._net is None:
            raise RuntimeError("PPODRIL: call init() first")
        return np.asarray(dril.reward(self.cfg.dril, self._net, state.reward_params, obs, action, next_obs))
