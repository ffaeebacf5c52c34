"""SQIL (Reddy et al. 2020): soft actor-critic with reward 1 on expert transitions and 0 on the agent's own.

Every batch is half expert, half agent transitions, each with its n-step target (constant rewards, so the n-step sum
is exact). Agent episodes end by truncation (``vec_env``) and always bootstrap. By default an expert demonstration's
end is a truncation too: demonstrations stop at success, the task does not end there. Treating it as a termination
(``expert_ends_terminal``, the original SQIL's use of the demonstrations' done flags) leaves the last expert states
with little future reward, so their value falls along the demonstration and the agent learns to stay near its start:
on the point-mass toy (tests/baselines) the policy turned back after 0.6 of the 1.0 it had to travel.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from poir_mjx.baselines import replay as rp
from poir_mjx.baselines.learner import ExpertData
from poir_mjx.baselines.offpolicy import CPU_SMALL_LOOP, LoopConfig, OffPolicyLearner
from poir_mjx.baselines.offpolicy import expert_normalizer
from poir_mjx.baselines.sac import SAC, Batch, SACConfig
from poir_mjx.core.normalizer import Normalizer
from poir_mjx.core.config import ConfigError
from poir_mjx.typed_config import check


@dataclasses.dataclass(frozen=True)
class Config:
    loop: LoopConfig = LoopConfig(replay_capacity=1_000_000)
    """Environments, warm-up, update ratio, batch 256, replay 1e6 (paper: replay 1e6)."""
    sac: SACConfig = SACConfig(learning_rate=1e-4)
    """The soft actor-critic (paper: DAC's sizes, lr 1e-4, 3-step returns)."""
    expert_fraction: float = 0.5
    """Share of each batch drawn from the expert data (SQIL: one half)."""
    expert_ends_terminal: bool = False
    """A demonstration's last transition is a termination (no bootstrap) instead of a truncation (see above)."""
    normalize_obs: bool = False
    """Standardise observations with the expert's statistics (the paper does so for DAC only)."""
    obs_std_floor: float = 1e-3
    """Smallest std of an observation dimension when normalising."""

    def validate(self) -> Config:
        return check(self)

    def cross_check(self, prefix: str) -> None:
        if not 0 < self.expert_fraction < 1:
            raise ConfigError(f"{prefix}expert_fraction: must be in (0, 1), got {self.expert_fraction}")


PRESETS = {
    "paper": Config(),
    # seconds-to-minutes on 2 CPU cores: small networks, small replay, few environments
    "cpu-small": Config(
        loop=CPU_SMALL_LOOP,
        sac=SACConfig(actor_layers=2, actor_width=64, critic_layers=2, critic_width=64, learning_rate=1e-4),
    ),
}


def window_batch(w: rp.Window, rewards: jax.Array, gamma: float, norm) -> Batch:
    """A SAC batch from n-step windows and per-step rewards [B, n] (``norm`` maps stored observations)."""
    ret, disc, last = rp.nstep_return(rewards, w.live, w.terminal, gamma)
    return Batch(obs=norm(w.obs[:, 0]), act=w.act[:, 0], reward=ret, discount=disc,
                 next_obs=norm(rp.at_last(w.next_obs, last)), weight=w.weight)  # fmt: skip


def concat(a: Batch, b: Batch) -> Batch:
    return jax.tree_util.tree_map(lambda x, y: jnp.concatenate([x, y]), a, b)


class SQIL(OffPolicyLearner):
    name = "sqil"

    def __init__(self, env, config: Config, obs_size: int, act_size: int):
        self.config = config.validate()
        super().__init__(env, config.loop, obs_size, act_size)
        self.sac = SAC(config.sac, obs_size, act_size)
        self.actor = self.sac.actor

    def make_normalizer(self, expert: ExpertData) -> Normalizer:
        return expert_normalizer(expert, self.config.normalize_obs, self.config.obs_std_floor)

    def prepare_expert(self, expert: ExpertData, norm: Normalizer) -> rp.Replay:
        terminal = expert.terminal if self.config.expert_ends_terminal else None
        return rp.from_expert(expert.obs, expert.actions, expert.next_obs, expert.terminal, terminal)

    def init_algo(self, key, expert, norm):
        return self.sac.init(key)

    def actor_params(self, algo):
        return algo.actor

    def explore(self, algo, norm, obs, key):
        keys = jax.random.split(key, obs.shape[0])
        return jax.vmap(self.sac.act, (None, 0, 0))(algo.actor, norm(obs), keys)

    def update(self, algo, replay, expert, norm, key):
        k_e, k_a, k_u = jax.random.split(key, 3)
        b, n, gamma = self.loop.batch_size, self.config.sac.n_step, self.config.sac.discount
        n_expert = min(max(round(b * self.config.expert_fraction), 1), b - 1)
        we = rp.sample_windows(expert, k_e, n_expert, n)
        wa = rp.sample_windows(replay, k_a, b - n_expert, n)
        batch = concat(window_batch(we, jnp.ones(we.live.shape), gamma, norm),
                       window_batch(wa, jnp.zeros(wa.live.shape), gamma, norm))  # fmt: skip
        return self.sac.update(algo, batch, k_u)

    def reward(self, algo, norm, tr, key):
        return jnp.zeros(tr.end.shape, jnp.float32)  # agent transitions: reward 0 by definition
