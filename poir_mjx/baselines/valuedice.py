"""ValueDICE (Kostrikov et al. 2020): off-policy distribution matching through a saddle point in nu(s, a) and pi.

With replay regularisation alpha, the objective is
    J(nu, pi) = log E_{(1-alpha) d_E + alpha d_RB}[exp(nu(s, a) - gamma nu(s', pi(s')))]
                - (1 - alpha)(1 - gamma) E_{s0 ~ expert initial states}[nu(s0, pi(s0))]
                - alpha E_{d_RB}[nu(s, a) - gamma nu(s', pi(s'))],
minimised by nu and maximised by pi (pi's actions are reparameterised samples of its tanh-Gaussian). Regularisers,
as in the official code (google-research/value_dice): nu gets a gradient penalty (||grad nu|| - 1)^2 on random
interpolates of expert and replay inputs, at (s, a) and at (s', pi(s')) (``nu_gradient_penalty``, 10 there); the policy
gets the orthogonal regulariser sum ||W^T W (1 - I)||^2 over its kernels (``policy_reg``: the paper's "policy reg
1e-4"). The initial-state term samples every expert state, as the official code and Acme do (any state distribution
the expert visits is a valid start for the shifted problem), or only the demonstrations' first states (``initial_states
= "first"``, the rows flagged ``initial``; on the toy this was markedly less stable). Observations are standardised
with the expert's statistics (the official code does). No absorbing states: an expert demonstration's last transition
bootstraps through nu(s', pi(s')) like a truncated agent episode.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Literal

import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax import struct

from poir_mjx.baselines import policy
from poir_mjx.baselines import replay as rp
from poir_mjx.baselines.learner import ExpertData
from poir_mjx.baselines.offpolicy import CPU_SMALL_LOOP, LoopConfig, OffPolicyLearner
from poir_mjx.baselines.offpolicy import expert_normalizer, wmean
from poir_mjx.core.normalizer import Normalizer
from poir_mjx.typed_config import check


@dataclasses.dataclass(frozen=True)
class Config:
    loop: LoopConfig = LoopConfig(replay_capacity=1_000_000)
    """Environments, warm-up, update ratio, batch 256 (paper), replay 1e6 (not in the paper)."""
    actor_layers: int = 2
    """Hidden layers of the policy (paper: MLPs 2 x 256)."""
    actor_width: int = 256
    """Units per policy hidden layer."""
    nu_layers: int = 2
    """Hidden layers of nu (paper: 2 x 256)."""
    nu_width: int = 256
    """Units per nu hidden layer."""
    nu_learning_rate: float = 0.01
    """Adam learning rate of nu (paper: 0.01; the official code's default is 1e-3)."""
    actor_learning_rate: float = 1e-5
    """Adam learning rate of the policy (paper: 1e-5)."""
    discount: float = 0.99
    """gamma (not in the paper; the official code's 0.99)."""
    replay_regularization: float = 0.05
    """alpha, the weight of the replay distribution in the objective (paper: 0.05)."""
    nu_gradient_penalty: float = 10.0
    """Weight of nu's gradient penalty (the official code's 10; not in the paper)."""
    policy_reg: float = 1e-4
    """Weight of the policy's orthogonal regularisation (paper: "policy reg 1e-4")."""
    initial_states: Literal["all", "first"] = "all"
    """States of the initial-state term: every expert state (official code, Acme) or the demonstrations' first."""
    normalize_obs: bool = True
    """Standardise observations with the expert's statistics (the official code does)."""
    obs_std_floor: float = 1e-3
    """Smallest std of an observation dimension when normalising."""

    OPEN_UNIT = ("discount",)
    UNIT = ("replay_regularization",)

    def validate(self) -> Config:
        return check(self)


PRESETS = {
    "paper": Config(),
    # seconds-to-minutes on 2 CPU cores: small networks, small replay, few environments; nu at the official code's
    # 1e-3 (on the toy, tests/baselines, 1e-3 with the paper's policy rate 1e-5 learned reliably)
    "cpu-small": Config(
        loop=CPU_SMALL_LOOP,
        actor_width=64, nu_width=64, nu_learning_rate=1e-3,
    ),
}


class ExpertSet(struct.PyTreeNode):
    obs: jax.Array  # [N, do], normalised
    act: jax.Array  # [N, da]
    next_obs: jax.Array  # [N, do]
    initial: jax.Array  # [M, do], the initial-state term's states (every expert state, or the demonstrations' first)


class VDState(struct.PyTreeNode):
    actor: Any
    nu: Any
    actor_opt: Any
    nu_opt: Any


def orthogonal_penalty(params) -> jax.Array:
    """sum over Dense kernels W of ||W^T W with its diagonal zeroed||^2 (BigGAN's orthogonal regularisation)."""
    total = jnp.zeros(())
    for path, w in jax.tree_util.tree_flatten_with_path(params)[0]:
        if getattr(path[-1], "key", None) == "kernel":
            prod = w.T @ w
            total = total + jnp.sum((prod * (1.0 - jnp.eye(prod.shape[0]))) ** 2)
    return total


class ValueDICE(OffPolicyLearner):
    name = "valuedice"

    def __init__(self, env, config: Config, obs_size: int, act_size: int):
        self.config = config.validate()
        super().__init__(env, config.loop, obs_size, act_size)
        self.actor = policy.TanhGaussianActor(act_size, config.actor_layers, config.actor_width)
        self.nu = policy.critic_mlp(config.nu_layers, config.nu_width)
        self.actor_opt = optax.adam(config.actor_learning_rate)
        self.nu_opt = optax.adam(config.nu_learning_rate)

    def make_normalizer(self, expert: ExpertData) -> Normalizer:
        return expert_normalizer(expert, self.config.normalize_obs, self.config.obs_std_floor)

    def prepare_expert(self, expert: ExpertData, norm: Normalizer) -> ExpertSet:
        first = self.config.initial_states == "first"
        initial = np.asarray(expert.obs)[np.asarray(expert.initial, bool)] if first else np.asarray(expert.obs)
        if initial.shape[0] == 0:
            raise ValueError("expert data: no transition is flagged initial (ValueDICE needs initial states)")
        f = lambda x: norm(jnp.asarray(x, jnp.float32))  # noqa: E731
        return ExpertSet(obs=f(expert.obs), act=jnp.asarray(expert.actions, jnp.float32), next_obs=f(expert.next_obs),
                         initial=f(initial))  # fmt: skip

    def init_algo(self, key, expert, norm) -> VDState:
        k_a, k_n = jax.random.split(key)
        actor = policy.init_mlp(self.actor, k_a, self.obs_size)
        nu = policy.init_mlp(self.nu, k_n, self.obs_size + self.act_size)
        return VDState(actor=actor, nu=nu, actor_opt=self.actor_opt.init(actor), nu_opt=self.nu_opt.init(nu))

    def actor_params(self, algo):
        return algo.actor

    def explore(self, algo, norm, obs, key):
        keys = jax.random.split(key, obs.shape[0])
        return jax.vmap(lambda o, k: policy.sample(self.actor, algo.actor, o, k)[0])(norm(obs), keys)

    def nu_fn(self, nu, obs, act):
        return self.nu.apply(nu, jnp.concatenate([obs, act], -1))[..., 0]

    def update(self, algo, replay, expert, norm, key):
        cfg, b = self.config, self.loop.batch_size
        gamma, alpha = cfg.discount, cfg.replay_regularization
        k_e, k_i, k_r, k_pi, k_gp = jax.random.split(key, 5)
        ie = jax.random.randint(k_e, (b,), 0, expert.obs.shape[0])
        s0 = expert.initial[jax.random.randint(k_i, (b,), 0, expert.initial.shape[0])]
        s_e, a_e, s2_e = expert.obs[ie], expert.act[ie], expert.next_obs[ie]
        w = rp.sample_windows(replay, k_r, b, 1)
        (s_r, a_r, s2_r), w_r = w.first(), w.weight
        s_r, s2_r = norm(s_r), norm(s2_r)
        k0, k1, k2 = jax.random.split(k_pi, 3)

        def objective(nu, actor):
            a0 = policy.sample(self.actor, actor, s0, k0)[0]
            a2_e = policy.sample(self.actor, actor, s2_e, k1)[0]
            a2_r = policy.sample(self.actor, actor, s2_r, k2)[0]
            diff_e = self.nu_fn(nu, s_e, a_e) - gamma * self.nu_fn(nu, s2_e, a2_e)
            diff_r = self.nu_fn(nu, s_r, a_r) - gamma * self.nu_fn(nu, s2_r, a2_r)
            weights = jnp.concatenate([jnp.full((b,), (1 - alpha) / b), alpha * w_r / jnp.maximum(w_r.sum(), 1.0)])
            nonlinear = jax.nn.logsumexp(jnp.concatenate([diff_e, diff_r]), b=weights)
            linear = (1 - alpha) * (1 - gamma) * jnp.mean(self.nu_fn(nu, s0, a0)) + alpha * wmean(diff_r, w_r)
            return nonlinear - linear, (a2_e, a2_r, diff_r)

        grad_fn = jax.value_and_grad(objective, (0, 1), has_aux=True)
        (j, (a2_e, a2_r, diff_r)), (g_nu, g_pi) = grad_fn(algo.nu, algo.actor)

        def penalty(nu):
            lam = jax.random.uniform(k_gp, (b, 1))
            cat = lambda s, a: jnp.concatenate([s, a], -1)  # noqa: E731
            x = jnp.concatenate([lam * cat(s_e, a_e) + (1 - lam) * cat(s_r, a_r),
                                 lam * cat(s2_e, a2_e) + (1 - lam) * cat(s2_r, a2_r)])  # fmt: skip
            x = jax.lax.stop_gradient(x)
            grads = jax.vmap(jax.grad(lambda xi: self.nu.apply(nu, xi)[0]))(x)
            return jnp.mean((jnp.sqrt(jnp.sum(grads**2, -1) + 1e-12) - 1.0) ** 2)

        gp, g_gp = jax.value_and_grad(penalty)(algo.nu)
        g_nu = jax.tree_util.tree_map(lambda a, c: a + cfg.nu_gradient_penalty * c, g_nu, g_gp)
        orth, g_orth = jax.value_and_grad(orthogonal_penalty)(algo.actor)
        g_pi = jax.tree_util.tree_map(lambda a, c: -a + cfg.policy_reg * c, g_pi, g_orth)
        upd, nu_opt = self.nu_opt.update(g_nu, algo.nu_opt, algo.nu)
        upd_pi, actor_opt = self.actor_opt.update(g_pi, algo.actor_opt, algo.actor)
        new = VDState(actor=optax.apply_updates(algo.actor, upd_pi), nu=optax.apply_updates(algo.nu, upd),
                      actor_opt=actor_opt, nu_opt=nu_opt)  # fmt: skip
        return new, {"objective": j, "nu_gp": gp, "orthogonal": orth, "replay_diff": wmean(diff_r, w_r)}

    def reward(self, algo, norm, tr, key):
        """-(nu(s, a) - gamma nu(s', pi(s'))): at the saddle point nu - B nu = log(d_pi / d_E) + const
        (Donsker-Varadhan), so this is ValueDICE's implicit reward, log d_E / d_pi up to a constant."""
        s, s2 = norm(tr.obs), norm(tr.next_obs)
        a2 = policy.sample(self.actor, algo.actor, s2, key)[0]
        return self.config.discount * self.nu_fn(algo.nu, s2, a2) - self.nu_fn(algo.nu, s, tr.act)
