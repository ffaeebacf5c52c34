"""PPO's networks and losses: a Gaussian policy with clipped actions, a value network, GAE and the clipped objective.

Actions: the policy is a diagonal Gaussian N(mu(s), exp(log_std)^2) with a learned state-independent ``log_std`` (as in
the PPO code DRIL builds on); the environment receives the sample clipped to [-1, 1], while log-probabilities and the
ratio use the unclipped sample (the clipped-Gaussian choice, rather than a tanh squash, keeps log-probs and entropy
exact and the deterministic evaluation action is simply clip(mu(s), -1, 1)). Observations reach the networks
standardised with the expert data's statistics and clipped to [-obs_clip, obs_clip].
"""

from __future__ import annotations

from typing import NamedTuple

import flax.linen as nn
import jax
import jax.numpy as jnp

from poir_mjx.core.ensemble import hidden_layers

LOG_2PI = float(jnp.log(2.0 * jnp.pi))


class PolicyNet(nn.Module):
    """``layers`` Dense layers (the output one included) -> action mean; plus the learned log std vector."""

    act_size: int
    layers: int
    width: int
    activation: str
    init_std: float

    @nn.compact
    def __call__(self, x):
        x = hidden_layers(x, self.layers, self.width, self.activation)
        # a small last layer: the untrained policy's mean is close to 0 whatever the observation
        mean = nn.Dense(self.act_size, kernel_init=nn.initializers.variance_scaling(0.01, "fan_in", "normal"))(x)
        log_std = self.param("log_std", nn.initializers.constant(jnp.log(self.init_std)), (self.act_size,))
        return mean, jnp.broadcast_to(log_std, mean.shape)


class ValueNet(nn.Module):
    layers: int
    width: int
    activation: str

    @nn.compact
    def __call__(self, x):
        x = hidden_layers(x, self.layers, self.width, self.activation)
        return nn.Dense(1)(x)[..., 0]


def log_prob(mean, log_std, action):
    """Diagonal Gaussian log-density, summed over action dimensions."""
    z = (action - mean) * jnp.exp(-log_std)
    return jnp.sum(-0.5 * z**2 - log_std - 0.5 * LOG_2PI, -1)


def entropy(log_std):
    return jnp.sum(log_std + 0.5 * (1.0 + LOG_2PI), -1)


class Batch(NamedTuple):
    """One unroll, [T, num_envs, ...] (flattened to [B, ...] for the updates)."""

    obs: jax.Array  # normalised observation the action was taken in
    action: jax.Array  # the unclipped Gaussian sample
    log_prob: jax.Array  # its log-probability under the acting policy
    advantage: jax.Array
    target: jax.Array  # value target: advantage + value


def gae(rewards, values, next_values, ended, terminal, discount: float, lam: float):
    """Generalised advantage estimation over one unroll [T, N].

    ``next_values`` is V of the observation each step led to (before any reset), so an episode truncated at
    ``episode_steps`` is bootstrapped from its last state; ``terminal`` steps (diverged physics) are not bootstrapped;
    ``ended`` cuts the recursion at episode boundaries. Returns (advantages, value targets), both [T, N].
    """
    deltas = rewards + discount * (1.0 - terminal) * next_values - values

    def body(acc, xs):
        delta, end = xs
        acc = delta + discount * lam * (1.0 - end) * acc
        return acc, acc

    _, adv = jax.lax.scan(body, jnp.zeros_like(deltas[0]), (deltas, ended), reverse=True)
    return adv, adv + values


class LossConfig(NamedTuple):
    clip_epsilon: float
    value_coef: float
    entropy_coef: float
    bc_coef: float


def loss(policy: PolicyNet, value: ValueNet, cfg: LossConfig, params, batch: Batch, expert_obs, expert_act):
    """Clipped surrogate + value_coef * 0.5 * value MSE - entropy_coef * entropy + bc_coef * BC MSE -> (loss, metrics).

    The BC term (DRIL's) is the squared error of the policy mean mu(s_e) to the expert's action (in [-1, 1]) on a
    minibatch of expert (normalised) observations; ``bc_coef = 0`` is plain PPO. Advantages are standardised per
    minibatch.
    """
    mean, log_std = policy.apply(params["policy"], batch.obs)
    ratio = jnp.exp(log_prob(mean, log_std, batch.action) - batch.log_prob)
    adv = (batch.advantage - batch.advantage.mean()) / (batch.advantage.std() + 1e-8)
    surrogate = jnp.minimum(ratio * adv, jnp.clip(ratio, 1 - cfg.clip_epsilon, 1 + cfg.clip_epsilon) * adv)
    policy_loss = -surrogate.mean()
    value_loss = 0.5 * jnp.mean((value.apply(params["value"], batch.obs) - batch.target) ** 2)
    ent = entropy(log_std).mean()
    expert_mean, _ = policy.apply(params["policy"], expert_obs)
    bc_loss = jnp.mean(jnp.sum((expert_mean - expert_act) ** 2, -1))
    total = policy_loss + cfg.value_coef * value_loss - cfg.entropy_coef * ent + cfg.bc_coef * bc_loss
    metrics = {"policy_loss": policy_loss, "value_loss": value_loss, "entropy": ent, "bc_loss": bc_loss,
               "clip_fraction": jnp.mean(jnp.abs(ratio - 1.0) > cfg.clip_epsilon)}  # fmt: skip
    return total, metrics
