"""The tanh-squashed Gaussian policy shared by SAC (SQIL, DAC) and ValueDICE, and the Q/nu networks' MLP.

The actor maps an observation to the mean and log-std of a diagonal Gaussian over pre-squash actions u; the action is
tanh(u), in (-1, 1). Its log-density includes the tanh change of variables. Evaluation uses tanh(mean).
"""

from __future__ import annotations

import flax.linen as nn
import jax
import jax.numpy as jnp

from poir_mjx.core.ensemble import MLP

LOG_STD_MIN, LOG_STD_MAX = -5.0, 2.0


class TanhGaussianActor(nn.Module):
    act_size: int
    layers: int  # hidden layers
    width: int

    @nn.compact
    def __call__(self, obs: jax.Array) -> tuple[jax.Array, jax.Array]:
        out = MLP(out=2 * self.act_size, layers=self.layers + 1, width=self.width)(obs)
        mean, raw = jnp.split(out, 2, axis=-1)
        log_std = LOG_STD_MIN + 0.5 * (LOG_STD_MAX - LOG_STD_MIN) * (jnp.tanh(raw) + 1.0)
        return mean, log_std


def critic_mlp(layers: int, width: int) -> MLP:
    """A scalar function of its input (Q(s, a) or nu(s, a) on concat(s, a)): ``layers`` hidden layers."""
    return MLP(out=1, layers=layers + 1, width=width)


def _log1m_tanh2(u: jax.Array) -> jax.Array:
    """log(1 - tanh(u)^2), computed stably."""
    return 2.0 * (jnp.log(2.0) - u - jax.nn.softplus(-2.0 * u))


def sample(actor: nn.Module, params, obs: jax.Array, key: jax.Array) -> tuple[jax.Array, jax.Array]:
    """A reparameterised action [..., da] and its log-density [...]."""
    mean, log_std = actor.apply(params, obs)
    eps = jax.random.normal(key, mean.shape, mean.dtype)
    u = mean + jnp.exp(log_std) * eps
    log_normal = -0.5 * eps**2 - log_std - 0.5 * jnp.log(2.0 * jnp.pi)
    return jnp.tanh(u), jnp.sum(log_normal - _log1m_tanh2(u), axis=-1)


def mode(actor: nn.Module, params, obs: jax.Array) -> jax.Array:
    """The deterministic (evaluation) action tanh(mean)."""
    return jnp.tanh(actor.apply(params, obs)[0])


def init_mlp(module: nn.Module, key: jax.Array, in_size: int):
    return module.init(key, jnp.zeros((1, in_size), jnp.float32))
