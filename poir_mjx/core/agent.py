"""POIR: a BC-ensemble prior, a world-model ensemble, an imitation reward and the planner that joins them.

Written once for every size: the ``cpu-small`` and ``paper`` presets differ only in numbers.

- BC / EBC act from the stacked BC ensemble (head 0 / mean of the K heads).
- The world model predicts the change of the normalised state: P_k(s, a) = s + f_k(s, a).
- ``plan(params, obs, key) -> action`` is the paper's SelectAction: N trajectories, horizon H,
  trajectory n keeps head n mod K for prior and model, imitation rewards summed over the H steps,
  top-k average of the first actions, clipped to the bounds. L2 and DRIL score the predicted
  state each action leads to, r(s^_{t+1}) for t = 1..H (``planner.reward_timing = "next_state"``);
  "current_state" is the printed r(s^_t, a~_t), s^_1 the real state; MOREL scores (s^_t, a~_t).

Networks, planner and rewards run in float32 whatever ``jax_enable_x64`` is (MJX physics may run
in float64): observations are cast to float32 on entry and actions come back in float32.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.cached import builder
from poir_mjx.core import ensemble as ens
from poir_mjx.core import rewards
from poir_mjx.core import candidates
from poir_mjx.core import selection as sel
from poir_mjx.core.config import ConfigError, POIRConfig
from poir_mjx.core.fit import fit
from poir_mjx.core.params import Imagined, POIRParams, TrainingDivergedError, check_losses  # noqa: F401  (re-exported)
from poir_mjx.core.selection import top_k_mean  # noqa: F401  (the planner's top-k, re-exported)


@dataclasses.dataclass(frozen=True)
class POIR:
    config: POIRConfig
    obs_size: int
    act_size: int

    @functools.cached_property
    def bc_module(self):
        """The BC heads as the agent acts and plans (their matmuls: PlannerConfig.matmul)."""
        return ens.make_mlp(self.config.bc, self.act_size, self.config.planner.matmul)

    @functools.cached_property
    def wm_module(self):
        """The world models as the planner imagines with them (PlannerConfig.matmul)."""
        return ens.make_mlp(self.config.world_model, self.obs_size, self.config.planner.matmul)

    @functools.cached_property
    def train_modules(self):
        """(BC, world model) as they are trained, offline and online: the backend's default matmul always."""
        return ens.make_mlp(self.config.bc, self.act_size), ens.make_mlp(self.config.world_model, self.obs_size)

    def __hash__(self):
        return hash((self.config, self.obs_size, self.act_size))

    def __post_init__(self):
        bad = [d for d in self.config.planner.l2_dims if d >= self.obs_size]
        if bad:
            raise ConfigError(f"planner.l2_dims: {bad[0]} is not a dimension of the {self.obs_size}-wide observation")

    # ------------------------------------------------------------------ training
    def fit(self, key: jax.Array, obs: np.ndarray, act: np.ndarray, next_obs: np.ndarray,
            **kw) -> tuple[POIRParams, dict]:
        """Train the BC (and world-model) ensembles on expert transitions: (params, loss history); keywords and
        details in ``core/fit.py``."""
        return fit(self, key, obs, act, next_obs, **kw)

    def disagreement_levels(self, params: POIRParams, s: jax.Array, a: jax.Array) -> dict:
        """The expert data's own DRIL and MOREL disagreement (normalised expert states `s` and actions `a`) at
        ``planner.disagreement_quantile``: what the "excess" rewards subtract."""
        q = self.config.planner.disagreement_quantile
        levels = {"dril_level": rewards.disagreement_level(_disagreement_fn(self, "dril"), params, s, q)}
        if params.reward_wm is not None:
            levels["morel_level"] = rewards.disagreement_level(_disagreement_fn(self, "morel"), params,
                                                               jnp.concatenate([s, a], -1), q)  # fmt: skip
        return levels

    # ------------------------------------------------------------------ policies
    def _clip(self, s_norm):
        """Normalised states as the networks and rewards see them (clipped when normalizer.clip > 0)."""
        c = self.config.normalizer.clip if self.config.normalize else 0.0
        return jnp.clip(s_norm, -c, c) if c > 0 else s_norm

    def normalize_obs(self, params: POIRParams, obs: jax.Array) -> jax.Array:
        return self._clip(params.obs_norm(jnp.asarray(obs, jnp.float32)))

    def _act_bounds(self, params):
        lo = params.act_norm(jnp.full(self.act_size, self.config.action_low, jnp.float32))
        hi = params.act_norm(jnp.full(self.act_size, self.config.action_high, jnp.float32))
        return lo, hi

    def _to_env_action(self, params, a_norm):
        return jnp.clip(params.act_norm.inverse(a_norm), self.config.action_low, self.config.action_high)

    # The BC ensemble in the planner's spaces (normalised states in, normalised actions out), whatever
    # space it was trained in (config.bc_space).
    def _in_planner_spaces(self, params: POIRParams, s_norm: jax.Array, apply) -> jax.Array:
        """`apply(states)` of the BC heads, fed and read in the planner's normalised spaces."""
        if self.config.bc_space != "raw":
            return apply(s_norm)
        return params.act_norm(apply(params.obs_norm.inverse(s_norm)))

    def _bc_all(self, params: POIRParams, s_norm: jax.Array) -> jax.Array:
        """Every head on the same states: [..., ds] -> [K, ..., da] (planner.head_chunk heads at a time)."""
        chunk = self.config.planner.head_chunk
        return self._in_planner_spaces(params, s_norm, lambda x: ens.apply_all(self.bc_module, params.bc, x, chunk))

    def _bc_each(self, params: POIRParams, s_norm: jax.Array) -> jax.Array:
        """Head k on its own states: [K, ..., ds] -> [K, ..., da]."""
        return self._in_planner_spaces(params, s_norm, lambda x: ens.apply_each(self.bc_module, params.bc, x))

    def _bc_env_actions(self, params: POIRParams, obs: jax.Array) -> jax.Array:
        """Every head's action for raw observations, in env units (unclipped): [K, da]."""
        if self.config.bc_space == "raw":
            return ens.apply_all(self.bc_module, params.bc, jnp.asarray(obs, jnp.float32))
        return params.act_norm.inverse(ens.apply_all(self.bc_module, params.bc, self.normalize_obs(params, obs)))

    def _act_clip(self, a):
        return jnp.clip(a, self.config.action_low, self.config.action_high)

    def bc_action(self, params: POIRParams, obs: jax.Array) -> jax.Array:
        """Plain BC: the first network of the ensemble."""
        return self._act_clip(self._bc_env_actions(params, obs)[0])

    def ebc_action(self, params: POIRParams, obs: jax.Array) -> jax.Array:
        """Ensemble BC (for a POIR agent: its prior alone): the mean of the K networks' actions."""
        if not self.config.normalize or self.config.bc_space == "raw":
            return self._act_clip(self._bc_env_actions(params, obs).mean(0))
        a = ens.apply_all(self.bc_module, params.bc, self.normalize_obs(params, obs)).mean(0)
        return self._to_env_action(params, a)

    # ------------------------------------------------------------------ planner
    def head_layout(self) -> tuple[int, int]:
        """(K, M): trajectory n = k + K j sits at [k, j]; M = ceil(N / K); cells with n >= N are masked."""
        k = self.config.ensemble_size
        return k, -(-self.config.planner.num_trajectories // k)

    def _dril(self, params: POIRParams, s: jax.Array) -> jax.Array:
        actions = self._bc_all(params, s)
        if self.config.planner.dril_units == "action":  # the heads' disagreement in robosuite's action units
            actions = actions * params.act_norm.std
        return rewards.dril_reward(actions)

    def _morel(self, params: POIRParams, s: jax.Array, a: jax.Array) -> jax.Array:
        """MOREL on the predicted next states as the rollout sees them (clipped when normalizer.clip > 0)."""
        deltas = ens.apply_all(self.wm_module, params.reward_wm, jnp.concatenate([s, a], -1), self.config.planner.head_chunk)
        clipped = self.config.normalize and self.config.normalizer.clip > 0
        return rewards.morel_reward(self._clip(s + deltas) if clipped else deltas)

    def trajectory_rewards(self, params: POIRParams, s: jax.Array, a: jax.Array) -> jax.Array:
        """r_IL(s, a) for states/actions laid out [K, M, .] (normalised) -> [K, M]."""
        pc = self.config.planner
        if pc.reward == "l2":
            flat, expert = s.reshape(-1, s.shape[-1]), params.expert_states
            if pc.l2_dims:  # the chosen observation dimensions only
                dims = jnp.asarray(pc.l2_dims)
                flat, expert = flat[:, dims], expert[:, dims]
            groups = math.prod(s.shape[:-2])  # one per head (and model, under all_models scoring): they lie together
            r = rewards.l2_reward(flat, expert, pc.l2_chunk, shortlist=pc.l2_shortlist, groups=groups)
            return r.reshape(s.shape[:-1])
        if pc.reward == "dril":
            r, level = self._dril(params, s), params.dril_level
        else:
            r, level = self._morel(params, s, a), params.morel_level
        return rewards.excess(r, level) if pc.disagreement == "excess" else r

    def scores_next_state(self) -> bool:
        """Whether the reward scores the state an action leads to (else the (s, a) it is taken in: MOREL always)."""
        pc = self.config.planner
        return pc.reward != "morel" and pc.reward_timing == "next_state"

    def rollouts(self, params: POIRParams, obs: jax.Array, key: jax.Array):
        """Imagined trajectories: returns (returns [K, M] with -inf on padding, first actions [K, M, da])."""
        ret, first, _ = self._imagine(params, obs, key, record=False)
        return ret, first

    def imagine(self, params: POIRParams, obs: jax.Array, key: jax.Array) -> Imagined:
        """The same imagined trajectories as ``rollouts`` (same key, same candidates), every step kept: what the
        planner forensics (poir_mjx/diagnose) read."""
        ret, _, (actions, states, step_rewards) = self._imagine(params, obs, key, record=True)
        s0 = jnp.broadcast_to(self.normalize_obs(params, obs), states.shape[1:])
        return Imagined(ret, actions, jnp.concatenate([s0[None], states]), step_rewards)

    def _imagine(self, params: POIRParams, obs: jax.Array, key: jax.Array, record: bool):
        pc = self.config.planner
        k, m = self.head_layout()
        lo, hi = self._act_bounds(params)
        s0 = jnp.broadcast_to(self.normalize_obs(params, obs), (k, m, self.obs_size))
        score_next = self.scores_next_state()
        keys = jax.random.split(key, pc.horizon)
        all_models = pc.scoring == "all_models"  # the actions are kept to roll them through every model

        def body(carry, xs):
            s, ret, first = carry
            t, kt = xs
            if pc.use_prior:
                prior = self._bc_each(params, s)
                a = prior + pc.sigma * jax.random.normal(kt, prior.shape, jnp.float32)
                if pc.gripper_noise == "flip":
                    a = candidates.flip_gripper(params.act_norm, prior, a, jax.random.fold_in(kt, 1),
                                                pc.gripper_flip_prob)  # fmt: skip
            else:
                a = jax.random.uniform(kt, (k, m, self.act_size), jnp.float32, minval=lo, maxval=hi)
            a = jnp.clip(a, lo, hi)
            s_next = self._clip(s + ens.apply_each(self.wm_module, params.wm, jnp.concatenate([s, a], -1)))
            r = self.trajectory_rewards(params, s_next if score_next else s, a)
            first = jnp.where(t == 0, a, first)
            return (s_next, ret + r, first), ((a, s_next, r) if record else a if all_models else None)

        init = (s0, jnp.zeros((k, m), jnp.float32), jnp.zeros((k, m, self.act_size), jnp.float32))
        (_, ret, first), steps = jax.lax.scan(body, init, (jnp.arange(pc.horizon), keys))
        real = sel.real_mask(k, m, pc.num_trajectories)
        if all_models:
            ret = candidates.all_models_score(self, params, s0, steps[0] if record else steps)
        ret = jnp.where(real, ret, -jnp.inf)
        if pc.scoring == "head_centred":
            ret = sel.head_centred(ret, real)
        return ret, first, steps

    def real_trajectories(self, ret: jax.Array, first: jax.Array) -> tuple[jax.Array, jax.Array]:
        """The N real trajectories of a [K, M] layout, in the order n = 0..N-1 (padding cells dropped):
        (returns [N], first actions [N, da])."""
        return sel.real_trajectories(ret, first, self.config.planner.num_trajectories)

    def plan(self, params: POIRParams, obs: jax.Array, key: jax.Array) -> jax.Array:
        """SelectAction: the mean first action of the top-k imagined trajectories, in env units (float32)."""
        ret, first = self.rollouts(params, obs, key)
        return self._to_env_action(params, self.select(ret, first, key))

    def select(self, ret: jax.Array, first: jax.Array, key: jax.Array) -> jax.Array:
        """The mean first action (normalised) of the top_k chosen among the real trajectories of a [K, M] layout
        (``core/selection.py``): the k best returns, k drawn uniformly ("random", from a key stream of its own, so
        the rollouts are those the same key's top-k planner scores) or the best of every head ("head_balanced")."""
        pc = self.config.planner
        return sel.select(pc.selection, ret, first, key, pc.num_trajectories, pc.top_k)


@builder(maxsize=32)
def _disagreement_fn(agent: POIR, reward: str):
    """jit((params, x) -> disagreement per row), one per agent config and reward: fits share its compilation.
    x is the normalised state (DRIL) or [state, action] (MOREL)."""
    if reward == "dril":
        return jax.jit(lambda p, x: -agent._dril(p, x))
    return jax.jit(lambda p, x: -agent._morel(p, x[:, : agent.obs_size], x[:, agent.obs_size :]))
