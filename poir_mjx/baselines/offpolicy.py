"""What SQIL, DAC and ValueDICE share: the collection/update loop, its config, the train state, the normaliser.

One ``train(state, iterations)`` call is one compiled function: ``lax.scan`` over iterations, each one step of all
``num_envs`` environments (uniform random actions during warm-up, the stochastic policy after) written to the device
replay, then ``updates_per_iteration`` gradient updates (``lax.scan``; none until ``warmup_steps`` environment steps,
whose update metrics are NaN).
A method subclasses ``OffPolicyLearner`` and supplies its networks (``init_algo``), its expert data on the device
(``prepare_expert``), exploration (``explore``), one update (``update``) and its reward on fresh transitions.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from poir_mjx.baselines import policy
from poir_mjx.baselines import replay as rp
from poir_mjx.baselines import vec_env
from poir_mjx.baselines.learner import ExpertData
from poir_mjx.core.normalizer import Normalizer
from poir_mjx.core.config import ConfigError


@dataclasses.dataclass(frozen=True)
class LoopConfig:
    """How one off-policy run steps its environments and interleaves gradient updates."""

    num_envs: int = 32
    """Environments stepped together; one iteration is num_envs environment steps."""
    episode_steps: int = 400
    """Control steps before a training episode is truncated (the sweep's max_steps; robosuite's horizon 400)."""
    total_env_steps: int = 500_000
    """Environment steps per run, all environments together (paper: 500k)."""
    eval_every: int = 50_000
    """Environment steps between evaluations of the deterministic policy (paper: 50k)."""
    warmup_steps: int = 10_000
    """Environment steps of uniform random actions before the first update (SAC's usual start; not in the paper)."""
    updates_per_iteration: int = 32
    """Gradient updates after each iteration; with num_envs 32 that is one update per environment step (Acme's
    default for SAC: 256 samples per insert at batch 256). The paper does not state its ratio."""
    batch_size: int = 256
    """Transitions per gradient update (paper: 256)."""
    replay_capacity: int = 3_000_000
    """Agent transitions kept, oldest overwritten first (paper: 3e6 for DAC, 1e6 for SQIL)."""

    ZERO_OK = ("warmup_steps",)

    def cross_check(self, prefix: str) -> None:
        if self.replay_capacity < self.num_envs:
            raise ConfigError(f"{prefix}replay_capacity: {self.replay_capacity} holds not one step of "
                              f"{self.num_envs} envs")  # fmt: skip


# The cpu-small loop shared by SQIL, DAC and ValueDICE: seconds-to-minutes on 2 CPU cores (few environments, a small
# replay, 8 updates per iteration of 8 environment steps).
CPU_SMALL_LOOP = LoopConfig(num_envs=8, episode_steps=400, total_env_steps=20_000, eval_every=10_000,
                            warmup_steps=1_000, updates_per_iteration=8, batch_size=128,
                            replay_capacity=20_000)  # fmt: skip


def expert_normalizer(expert: ExpertData, enabled: bool, std_floor: float) -> Normalizer:
    """Mean 0 / std 1 on the expert's observations (std at least ``std_floor``); the identity when not enabled."""
    return Normalizer.fit(np.asarray(expert.obs, np.float32), enabled, std_floor)


class TrainState(struct.PyTreeNode):
    algo: Any  # the method's networks and optimiser states
    replay: rp.Replay  # the agent's transitions
    expert: Any  # the method's expert data on the device
    norm: Normalizer
    env: vec_env.VecState
    key: jax.Array
    env_steps: jax.Array  # int32 scalar


def wmean(x: jax.Array, w: jax.Array) -> jax.Array:
    """sum(w x) / sum(w) over [B] (0 when every weight is 0)."""
    return jnp.sum(x * w) / jnp.maximum(jnp.sum(w), 1e-6)


class OffPolicyLearner:
    """The shared loop; subclasses set ``name``, ``actor`` and the hooks below."""

    name: str = ""

    def __init__(self, env, loop: LoopConfig, obs_size: int, act_size: int):
        self.loop, self.obs_size, self.act_size = loop, obs_size, act_size
        self.vec = vec_env.VecEnv(env, loop.num_envs, loop.episode_steps)
        self._train = jax.jit(self._train_impl, static_argnums=1)

    @property
    def env_steps_per_iteration(self) -> int:
        """Environment steps one ``train`` iteration takes: a step of every environment."""
        return self.loop.num_envs

    # ---- hooks -------------------------------------------------------------------------------------------------
    def make_normalizer(self, expert: ExpertData) -> Normalizer:
        return expert_normalizer(expert, False, 0.0)

    def init_algo(self, key: jax.Array, expert: Any, norm: Normalizer) -> Any:
        raise NotImplementedError

    def prepare_expert(self, expert: ExpertData, norm: Normalizer) -> Any:
        raise NotImplementedError

    def actor_input(self, norm: Normalizer, obs: jax.Array) -> jax.Array:
        """What the actor sees of an environment observation (normalised; DAC adds its absorbing flag)."""
        return norm(obs)

    def actor_params(self, algo) -> Any:
        raise NotImplementedError

    def explore(self, algo, norm: Normalizer, obs: jax.Array, key: jax.Array) -> jax.Array:
        """Actions [E, da] of the stochastic policy, one key per environment."""
        raise NotImplementedError

    def update(self, algo, replay: rp.Replay, expert, norm: Normalizer, key: jax.Array) -> tuple[Any, dict]:
        raise NotImplementedError

    def reward(self, algo, norm: Normalizer, tr: vec_env.Transition, key: jax.Array) -> jax.Array:
        """The method's own reward of fresh agent transitions [E] (the imitation_reward metric)."""
        raise NotImplementedError

    # ---- the Learner protocol ---------------------------------------------------------------------------------
    def init(self, key: jax.Array, expert: ExpertData, env_params: Any) -> TrainState:
        if expert.obs.shape[1] != self.obs_size or expert.actions.shape[1] != self.act_size:
            raise ValueError(f"expert data: obs/action sizes {expert.obs.shape[1]}/{expert.actions.shape[1]}, "
                             f"the learner was built for {self.obs_size}/{self.act_size}")  # fmt: skip
        k_algo, k_env, k_run = jax.random.split(key, 3)
        norm = self.make_normalizer(expert)
        prepared = self.prepare_expert(expert, norm)
        return TrainState(
            algo=self.init_algo(k_algo, prepared, norm),
            replay=rp.init(self.loop.replay_capacity, self.loop.num_envs, self.obs_size, self.act_size),
            expert=prepared, norm=norm, env=self.vec.reset(k_env, env_params), key=k_run,
            env_steps=jnp.zeros((), jnp.int32),
        )  # fmt: skip

    def train(self, state: TrainState, iterations: int) -> tuple[TrainState, dict[str, jax.Array]]:
        return self._train(state, int(iterations))

    def env_steps(self, state: TrainState) -> jax.Array:
        return state.env_steps

    def policy_params(self, state: TrainState) -> Any:
        return (self.actor_params(state.algo), state.norm)

    def policy_fn(self) -> Callable[[Any, jax.Array, jax.Array], jax.Array]:
        def act(params, obs, key):
            actor_params, norm = params
            return policy.mode(self.actor, actor_params, self.actor_input(norm, obs.astype(jnp.float32)))

        return act

    # ---- the compiled phase -----------------------------------------------------------------------------------
    def _train_impl(self, state: TrainState, iterations: int):
        loop, e = self.loop, self.loop.num_envs

        def learn(algo, replay, expert, norm, key):
            def body(a, k):
                return self.update(a, replay, expert, norm, k)

            algo, metrics = jax.lax.scan(body, algo, jax.random.split(key, loop.updates_per_iteration))
            return algo, jax.tree_util.tree_map(jnp.mean, metrics)

        def iteration(st: TrainState, _):
            key, k_act, k_rand, k_env, k_upd, k_rew = jax.random.split(st.key, 6)
            warm = st.env_steps < loop.warmup_steps
            random_a = jax.random.uniform(k_rand, (e, self.act_size), jnp.float32, -1.0, 1.0)
            a = jnp.where(warm, random_a, self.explore(st.algo, st.norm, st.env.obs, k_act))
            env, tr = self.vec.step(st.env, a, k_env)
            replay = rp.add(st.replay, tr.obs, tr.act, tr.next_obs, tr.end, tr.valid)
            steps = st.env_steps + e
            shapes = jax.eval_shape(learn, st.algo, replay, st.expert, st.norm, k_upd)[1]

            def skip(algo, *_):  # warm-up: no update, its metrics NaN
                return algo, jax.tree_util.tree_map(lambda s: jnp.full(s.shape, jnp.nan, s.dtype), shapes)

            updating = steps >= loop.warmup_steps
            algo, metrics = jax.lax.cond(updating, learn, skip, st.algo, replay, st.expert, st.norm, k_upd)
            r = self.reward(algo, st.norm, tr, k_rew)
            metrics = dict(metrics, imitation_reward=wmean(r, tr.valid.astype(jnp.float32)),
                           episode_success=vec_env.episode_success(tr), updating=updating.astype(jnp.float32))
            return st.replace(algo=algo, replay=replay, env=env, key=key, env_steps=steps), metrics

        return jax.lax.scan(iteration, state, None, length=iterations)
