"""Soft actor-critic with a pluggable reward: the update takes a batch whose (n-step) rewards are already computed.

Tanh-Gaussian actor, twin critics (stacked parameters applied with vmap) with Polyak-averaged targets, and a learned
temperature alpha driven to a target entropy of -entropy_scale x act_size. SQIL and DAC build their batches (rewards,
bootstrap discounts, n-step next observations) and call ``SAC.update``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import optax
from flax import struct

from poir_mjx.baselines import policy
from poir_mjx.baselines.offpolicy import wmean
from poir_mjx.core.ensemble import apply_all, init_ensemble


@dataclasses.dataclass(frozen=True)
class SACConfig:
    actor_layers: int = 2
    """Hidden layers of the policy MLP (paper, DAC and SQIL: 2 x 256)."""
    actor_width: int = 256
    """Units per policy hidden layer."""
    critic_layers: int = 3
    """Hidden layers of each critic MLP (paper: 3 x 512)."""
    critic_width: int = 512
    """Units per critic hidden layer."""
    learning_rate: float = 3e-4
    """Adam learning rate of the actor, the critics and the temperature (paper: DAC 3e-4, SQIL 1e-4)."""
    discount: float = 0.97
    """gamma (paper: 0.97 for DAC; SQIL "same as DAC")."""
    n_step: int = 3
    """Transitions summed in each TD target (paper: 3-step returns)."""
    tau: float = 0.005
    """Polyak rate of the target critics (SAC's usual value; not in the paper)."""
    init_alpha: float = 1.0
    """Initial temperature (SAC's usual 1.0)."""
    learn_alpha: bool = True
    """Adapt alpha towards the target entropy (SAC's usual); False keeps it at init_alpha."""
    entropy_scale: float = 1.0
    """Target entropy is -entropy_scale x act_size (SAC's usual -act_size)."""

    OPEN_UNIT = ("discount",)


class Batch(struct.PyTreeNode):
    obs: jax.Array  # [B, do]
    act: jax.Array  # [B, da]
    reward: jax.Array  # [B], the n-step discounted reward sum
    discount: jax.Array  # [B], gamma^m, or 0 after a true termination
    next_obs: jax.Array  # [B, do], the observation the target bootstraps from
    weight: jax.Array  # [B], 0 for padding / invalid rows


class SACState(struct.PyTreeNode):
    actor: Any
    critic: Any  # twin critics, stacked [2, ...]
    target: Any
    log_alpha: jax.Array
    actor_opt: Any
    critic_opt: Any
    alpha_opt: Any


class SAC:
    def __init__(self, cfg: SACConfig, obs_size: int, act_size: int):
        self.cfg, self.obs_size, self.act_size = cfg, obs_size, act_size
        self.actor = policy.TanhGaussianActor(act_size, cfg.actor_layers, cfg.actor_width)
        self.critic = policy.critic_mlp(cfg.critic_layers, cfg.critic_width)
        self.opt = optax.adam(cfg.learning_rate)
        self.target_entropy = -cfg.entropy_scale * act_size

    def init(self, key: jax.Array) -> SACState:
        k_actor, k_critic = jax.random.split(key)
        actor = policy.init_mlp(self.actor, k_actor, self.obs_size)
        critic = init_ensemble(self.critic, k_critic, 2, self.obs_size + self.act_size)
        log_alpha = jnp.log(jnp.asarray(self.cfg.init_alpha, jnp.float32))
        return SACState(actor=actor, critic=critic, target=critic, log_alpha=log_alpha, actor_opt=self.opt.init(actor),
                        critic_opt=self.opt.init(critic), alpha_opt=self.opt.init(log_alpha))  # fmt: skip

    def q(self, critic, obs: jax.Array, act: jax.Array) -> jax.Array:
        """Both critics: [2, B]."""
        return apply_all(self.critic, critic, jnp.concatenate([obs, act], -1))[..., 0]

    def act(self, actor, obs: jax.Array, key: jax.Array) -> jax.Array:
        return policy.sample(self.actor, actor, obs, key)[0]

    def update(self, st: SACState, b: Batch, key: jax.Array) -> tuple[SACState, dict[str, jax.Array]]:
        k_next, k_pi = jax.random.split(key)
        alpha = jnp.exp(st.log_alpha)
        a_next, logp_next = policy.sample(self.actor, st.actor, b.next_obs, k_next)
        v_next = jnp.min(self.q(st.target, b.next_obs, a_next), 0) - alpha * logp_next
        y = jax.lax.stop_gradient(b.reward + b.discount * v_next)

        def critic_loss(c):
            q = self.q(c, b.obs, b.act)
            return wmean(0.5 * jnp.sum((q - y) ** 2, 0), b.weight), q

        (c_loss, q), g = jax.value_and_grad(critic_loss, has_aux=True)(st.critic)
        upd, critic_opt = self.opt.update(g, st.critic_opt, st.critic)
        critic = optax.apply_updates(st.critic, upd)

        def actor_loss(p):
            a, logp = policy.sample(self.actor, p, b.obs, k_pi)
            return wmean(alpha * logp - jnp.min(self.q(critic, b.obs, a), 0), b.weight), logp

        (a_loss, logp), g = jax.value_and_grad(actor_loss, has_aux=True)(st.actor)
        upd, actor_opt = self.opt.update(g, st.actor_opt, st.actor)
        actor = optax.apply_updates(st.actor, upd)

        entropy_gap = jax.lax.stop_gradient(logp + self.target_entropy)
        g = jax.grad(lambda la: wmean(-la * entropy_gap, b.weight))(st.log_alpha)
        upd, alpha_opt = self.opt.update(g, st.alpha_opt, st.log_alpha)
        log_alpha = optax.apply_updates(st.log_alpha, upd) if self.cfg.learn_alpha else st.log_alpha

        target = optax.incremental_update(critic, st.target, self.cfg.tau)
        metrics = {"critic_loss": c_loss, "actor_loss": a_loss, "alpha": alpha, "q": wmean(q.mean(0), b.weight),
                   "entropy": -wmean(logp, b.weight)}  # fmt: skip
        new = SACState(actor=actor, critic=critic, target=target, log_alpha=log_alpha, actor_opt=actor_opt,
                       critic_opt=critic_opt, alpha_opt=alpha_opt)  # fmt: skip
        return new, metrics
