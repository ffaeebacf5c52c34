"""Ensembles of MLPs as one set of stacked parameters, applied and trained with ``vmap``.

Every member has its own initialisation and its own minibatch order. One SGD epoch is one
compiled function (``lax.scan`` over minibatches, ``vmap`` over members). Parameters, inputs and
computation are float32 whatever ``jax_enable_x64`` is.
"""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import flax.linen as nn
import jax
import jax.numpy as jnp
import optax

from poir_mjx.cached import builder
from poir_mjx.core.config import MLPConfig, TrainConfig

ACTIVATIONS = {"relu": nn.relu, "tanh": nn.tanh, "gelu": nn.gelu}


def hidden_layers(x, layers: int, width: int, activation: str, **dense):
    """The hidden part of a ``layers``-Dense MLP (all but the output layer), called inside a compact module
    (its Dense layers are that module's Dense_0, Dense_1, ...); `dense`: nn.Dense's keyword arguments."""
    for _ in range(layers - 1):
        x = ACTIVATIONS[activation](nn.Dense(width, **dense)(x))
    return x


def round_to_tf32(x: jax.Array) -> jax.Array:
    """float32 rounded to the nearest TF32 value (10 explicit mantissa bits, ties to even), kept as float32."""
    bits = jax.lax.bitcast_convert_type(x, jnp.uint32)
    bits = (bits + jnp.uint32(0x0FFF) + ((bits >> 13) & jnp.uint32(1))) & jnp.uint32(0xFFFFE000)
    return jax.lax.bitcast_convert_type(bits, jnp.float32)


def matmul_dot_general(matmul: str):
    """nn.Dense's dot_general for a matmul setting (PlannerConfig.matmul); None: flax's, the backend's default.
    "tf32" rounds both inputs to TF32 and asks for the backend's DEFAULT precision explicitly, whatever
    jax_default_matmul_precision says (TF32 tensor cores on a GPU, true float32 of the rounded inputs on a CPU:
    the same products); "bfloat16" multiplies bfloat16 inputs with
    float32 accumulation on every backend."""
    if matmul == "default":
        return None
    if matmul == "float32":
        return functools.partial(jax.lax.dot_general, precision=jax.lax.Precision.HIGHEST)
    if matmul not in ("tf32", "bfloat16"):
        raise ValueError(f"matmul: {matmul!r} is not one of default, float32, tf32, bfloat16")
    low = round_to_tf32 if matmul == "tf32" else (lambda v: v.astype(jnp.bfloat16))

    def dot_general(lhs, rhs, dimension_numbers, precision=None, preferred_element_type=None, **kw):
        return jax.lax.dot_general(low(lhs), low(rhs), dimension_numbers, precision=jax.lax.Precision.DEFAULT,
                                   preferred_element_type=jnp.float32)  # fmt: skip

    return dot_general


class MLP(nn.Module):
    out: int
    layers: int
    width: int
    activation: str = "relu"
    matmul: str = "default"

    @nn.compact
    def __call__(self, x):
        dense = dict(dtype=jnp.float32, param_dtype=jnp.float32, dot_general=matmul_dot_general(self.matmul))
        x = hidden_layers(x, self.layers, self.width, self.activation, **dense)
        return nn.Dense(self.out, **dense)(x)


def make_mlp(cfg: MLPConfig, out: int, matmul: str = "default") -> MLP:
    """The MLP for `cfg`; `matmul` sets how it multiplies (PlannerConfig.matmul), not its parameters."""
    return MLP(out=out, layers=cfg.layers, width=cfg.width, activation=cfg.activation, matmul=matmul)


def init_ensemble(module: nn.Module, key: jax.Array, k: int, in_size: int) -> Any:
    """K independent initialisations, stacked on a leading axis."""
    return jax.vmap(lambda kk: module.init(kk, jnp.zeros((1, in_size), jnp.float32)))(jax.random.split(key, k))


def ensemble_size(params) -> int:
    return jax.tree_util.tree_leaves(params)[0].shape[0]


def apply_all(module: nn.Module, params, x: jax.Array, chunk: int = 0) -> jax.Array:
    """Every member on the same input: x [..., d] -> [K, ..., out]. chunk > 0: that many members at a time
    (``lax.map``), which bounds the activations held at once to chunk x |x| instead of K x |x|."""
    if 0 < chunk < ensemble_size(params):
        return jax.lax.map(lambda p: module.apply(p, x), params, batch_size=chunk)
    return jax.vmap(lambda p: module.apply(p, x))(params)


def apply_each(module: nn.Module, params, x: jax.Array) -> jax.Array:
    """Member k on its own inputs: x [K, ..., d] -> [K, ..., out]."""
    return jax.vmap(module.apply)(params, x)


class TrainState(NamedTuple):
    params: Any
    opt_state: Any


@builder
def make_optimizer(cfg: TrainConfig) -> optax.GradientTransformation:
    """Adam for `cfg`; one object per config, so ``train_epoch`` (static in it) compiles once per shape."""
    return optax.adam(cfg.learning_rate, b1=cfg.beta1, b2=cfg.beta2)


def init_train_state(params, optimizer) -> TrainState:
    return TrainState(params, jax.vmap(optimizer.init)(params))


def member_update(optimizer, loss_fn, params, opt_state, *batch):
    """One optimiser step of one ensemble member on ``loss_fn(params, *batch)``: (params, opt_state, loss)."""
    loss, g = jax.value_and_grad(loss_fn)(params, *batch)
    upd, opt_state = optimizer.update(g, opt_state, params)
    return optax.apply_updates(params, upd), opt_state, loss


@functools.partial(jax.jit, static_argnames=("module", "optimizer", "batch_size"))
def train_epoch(module, optimizer, batch_size: int, state: TrainState, x, y, key, weights=None):
    """One epoch of MSE regression x -> y for every member (own shuffle each); returns (state, mean loss [K]).

    weights [out]: each output dimension's weight in the squared error (None: all 1)."""
    x, y = jnp.asarray(x, jnp.float32), jnp.asarray(y, jnp.float32)
    w = jnp.ones(y.shape[-1], jnp.float32) if weights is None else jnp.asarray(weights, jnp.float32)
    k = ensemble_size(state.params)
    n = x.shape[0]
    if n < batch_size:
        raise ValueError(f"batch_size: {batch_size} exceeds the number of training samples {n}")
    steps = n // batch_size
    perms = jax.vmap(lambda kk: jax.random.permutation(kk, n))(jax.random.split(key, k))
    perms = perms[:, : steps * batch_size].reshape(k, steps, batch_size).transpose(1, 0, 2)

    def loss_fn(p, xb, yb):
        return jnp.mean(jnp.sum(w * (module.apply(p, xb) - yb) ** 2, -1))

    def member_step(p, o, idx):
        return member_update(optimizer, loss_fn, p, o, x[idx], y[idx])

    def body(carry, idx):
        p, o = carry
        p, o, loss = jax.vmap(member_step)(p, o, idx)
        return (p, o), loss

    (p, o), losses = jax.lax.scan(body, (state.params, state.opt_state), perms)
    return TrainState(p, o), losses.mean(0)


def mse(module, params, x, y) -> jax.Array:
    """Per-member mean squared error (summed over output dims) on (x, y)."""
    pred = apply_all(module, params, x)
    return jnp.mean(jnp.sum((pred - y) ** 2, -1), axis=-1)
