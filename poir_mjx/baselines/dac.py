"""DAC, Discriminator-Actor-Critic (Kostrikov et al. 2019): SAC on the reward ln D(s, a) - ln(1 - D(s, a)).

Each update first trains the discriminator D (an MLP on normalised (s, a), logits) to tell expert pairs (label 1)
from the agent's replay (label 0), with a gradient penalty (||grad_x logit|| - 1)^2 on random interpolates of an
expert and an agent pair; then one SAC update on agent n-step windows whose rewards are the logit of the updated D.

Observations are standardised with the expert's statistics. Absorbing states: observations carry one more dimension,
0 for a real state; the absorbing state is all zeros with that flag 1. An expert demonstration's terminal transition
leads to it, and each demonstration contributes one absorbing pair (absorbing state, zero action) to the expert set,
so D learns whether ending (and staying ended) is expert-like. The agent's episodes end by truncation only in this
project's environments (``vec_env``), so agent transitions are never absorbing and the critic never bootstraps into
the absorbing state; it matters through the discriminator. The policy is trained on agent transitions only (DAC).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax import struct

from poir_mjx.baselines import replay as rp
from poir_mjx.baselines.learner import ExpertData
from poir_mjx.baselines.offpolicy import CPU_SMALL_LOOP, LoopConfig, OffPolicyLearner
from poir_mjx.baselines.offpolicy import expert_normalizer, wmean
from poir_mjx.baselines.policy import critic_mlp, init_mlp
from poir_mjx.baselines.sac import SAC, SACConfig, SACState
from poir_mjx.baselines.sqil import window_batch
from poir_mjx.core.normalizer import Normalizer
from poir_mjx.typed_config import check


@dataclasses.dataclass(frozen=True)
class Config:
    loop: LoopConfig = LoopConfig()
    """Environments, warm-up, update ratio, batch 256, replay 3e6 (paper: batch 256, replay 3e6)."""
    sac: SACConfig = SACConfig()
    """The soft actor-critic (paper: policy 2 x 256, critic 3 x 512, discount 0.97, lr 3e-4, 3-step returns)."""
    disc_layers: int = 2
    """Hidden layers of the discriminator (paper: 2 x 128)."""
    disc_width: int = 128
    """Units per discriminator hidden layer."""
    disc_learning_rate: float = 3e-4
    """Adam learning rate of the discriminator (the paper's DAC lr, 3e-4)."""
    gradient_penalty: float = 10.0
    """Weight of the discriminator's gradient penalty (paper: 10)."""
    absorbing: bool = True
    """Absorbing-state wrapper for the expert demonstrations' ends (paper: yes)."""
    normalize_obs: bool = True
    """Standardise observations with the expert's statistics (paper: yes)."""
    obs_std_floor: float = 1e-3
    """Smallest std of an observation dimension when normalising."""

    def validate(self) -> Config:
        return check(self)


PRESETS = {
    "paper": Config(),
    # seconds-to-minutes on 2 CPU cores: small networks, small replay, few environments
    "cpu-small": Config(
        loop=CPU_SMALL_LOOP,
        sac=SACConfig(actor_layers=2, actor_width=64, critic_layers=2, critic_width=64),
        disc_layers=2, disc_width=64,
    ),
}


class DACState(struct.PyTreeNode):
    sac: SACState
    disc: Any
    disc_opt: Any


class ExpertPairs(struct.PyTreeNode):
    obs: jax.Array  # [M, do + absorbing flag], normalised
    act: jax.Array  # [M, da]


class DAC(OffPolicyLearner):
    name = "dac"

    def __init__(self, env, config: Config, obs_size: int, act_size: int):
        self.config = config.validate()
        super().__init__(env, config.loop, obs_size, act_size)
        self.in_size = obs_size + int(config.absorbing)
        self.sac = SAC(config.sac, self.in_size, act_size)
        self.actor = self.sac.actor
        self.disc = critic_mlp(config.disc_layers, config.disc_width)
        self.disc_opt = optax.adam(config.disc_learning_rate)

    # observations as the networks see them
    def actor_input(self, norm: Normalizer, obs: jax.Array) -> jax.Array:
        x = norm(obs)
        return jnp.concatenate([x, jnp.zeros(x.shape[:-1] + (1,), x.dtype)], -1) if self.config.absorbing else x

    def make_normalizer(self, expert: ExpertData) -> Normalizer:
        return expert_normalizer(expert, self.config.normalize_obs, self.config.obs_std_floor)

    def prepare_expert(self, expert: ExpertData, norm: Normalizer) -> ExpertPairs:
        obs = np.asarray(self.actor_input(norm, jnp.asarray(expert.obs, jnp.float32)))
        act = np.asarray(expert.actions, np.float32)
        n_end = int(np.sum(expert.terminal)) if self.config.absorbing else 0
        absorbing = np.zeros((n_end, self.in_size), np.float32)
        absorbing[:, -1] = 1.0
        return ExpertPairs(obs=jnp.asarray(np.concatenate([obs, absorbing])),
                           act=jnp.asarray(np.concatenate([act, np.zeros((n_end, act.shape[1]), np.float32)])))

    def init_algo(self, key, expert, norm) -> DACState:
        k_sac, k_disc = jax.random.split(key)
        disc = init_mlp(self.disc, k_disc, self.in_size + self.act_size)
        return DACState(sac=self.sac.init(k_sac), disc=disc, disc_opt=self.disc_opt.init(disc))

    def actor_params(self, algo):
        return algo.sac.actor

    def logit(self, disc, obs: jax.Array, act: jax.Array) -> jax.Array:
        """ln D - ln(1 - D) on network inputs (normalised, flagged) [..., d] -> [...]."""
        return self.disc.apply(disc, jnp.concatenate([obs, act], -1))[..., 0]

    def explore(self, algo, norm, obs, key):
        keys = jax.random.split(key, obs.shape[0])
        return jax.vmap(self.sac.act, (None, 0, 0))(algo.sac.actor, self.actor_input(norm, obs), keys)

    def disc_update(self, algo: DACState, expert: ExpertPairs, obs, act, weight, key):
        """One discriminator step: expert pairs sampled here vs the agent's (obs, act, weight) [B]."""
        k_idx, k_mix = jax.random.split(key)
        idx = jax.random.randint(k_idx, (obs.shape[0],), 0, expert.obs.shape[0])
        e_in = jnp.concatenate([expert.obs[idx], expert.act[idx]], -1)
        a_in = jnp.concatenate([obs, act], -1)
        lam = jax.random.uniform(k_mix, (obs.shape[0], 1))
        mix = lam * e_in + (1 - lam) * a_in
        f = lambda p, x: self.disc.apply(p, x)[..., 0]  # noqa: E731

        def loss(p):
            l_e, l_a = f(p, e_in), f(p, a_in)
            bce = jnp.mean(jax.nn.softplus(-l_e)) + wmean(jax.nn.softplus(l_a), weight)
            grads = jax.vmap(jax.grad(lambda x: f(p, x)))(mix)
            gp = wmean((jnp.sqrt(jnp.sum(grads**2, -1) + 1e-12) - 1.0) ** 2, weight)
            acc = 0.5 * (jnp.mean(l_e > 0) + wmean((l_a < 0).astype(jnp.float32), weight))
            return bce + self.config.gradient_penalty * gp, {"disc_loss": bce, "disc_gp": gp, "disc_accuracy": acc}

        (_, metrics), g = jax.value_and_grad(loss, has_aux=True)(algo.disc)
        upd, disc_opt = self.disc_opt.update(g, algo.disc_opt, algo.disc)
        return algo.replace(disc=optax.apply_updates(algo.disc, upd), disc_opt=disc_opt), metrics

    def update(self, algo, replay, expert, norm, key):
        k_w, k_d, k_u = jax.random.split(key, 3)
        w = rp.sample_windows(replay, k_w, self.loop.batch_size, self.config.sac.n_step)
        obs, next_obs = self.actor_input(norm, w.obs), self.actor_input(norm, w.next_obs)
        algo, d_metrics = self.disc_update(algo, expert, obs[:, 0], w.act[:, 0], w.weight, k_d)
        rewards = jax.lax.stop_gradient(self.logit(algo.disc, obs, w.act))  # [B, n]
        flagged = w.replace(obs=obs, next_obs=next_obs)
        batch = window_batch(flagged, rewards, self.config.sac.discount, lambda x: x)
        sac, metrics = self.sac.update(algo.sac, batch, k_u)
        return algo.replace(sac=sac), dict(metrics, **d_metrics, reward=wmean(rewards[:, 0], w.weight))

    def reward(self, algo, norm, tr, key):
        return self.logit(algo.disc, self.actor_input(norm, tr.obs), tr.act)
