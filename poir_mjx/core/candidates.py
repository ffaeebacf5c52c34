"""Two planner options that change how candidates are proposed or scored (``PlannerConfig.gripper_noise`` and
``scoring: "all_models"``), written as functions of the agent so the planner's rollout stays one readable loop."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from poir_mjx.core import ensemble as ens


def flip_gripper(act_norm, prior: jax.Array, a: jax.Array, key: jax.Array, prob: float) -> jax.Array:
    """gripper_noise "flip": the candidates' gripper command (the last dimension of the normalised actions `a`) set
    to a full command with the prior's sign, reversed with probability `prob` (robosuite acts on the gripper
    command's sign only, so Gaussian noise on it rarely changes what the robot does)."""
    sign = jnp.where(act_norm.inverse(prior)[..., -1] >= 0, 1.0, -1.0)
    flip = jax.random.bernoulli(key, prob, sign.shape)
    env = act_norm.inverse(a).at[..., -1].set(jnp.where(flip, -sign, sign))
    return act_norm(env)


def all_models_score(agent, params, s0: jax.Array, actions: jax.Array) -> jax.Array:
    """scoring "all_models": each trajectory's actions [H, K, M, da] rolled open-loop from s0 [K, M, ds] through
    every world model of the ensemble; the mean of the K models' returns minus scoring_lambda times their std,
    [K, M] (the paper's "average reward over all ensemble members")."""
    kw = agent.config.ensemble_size
    score_next = agent.scores_next_state()

    def body(s, a):  # s [Kw, K, M, ds]: model w's prediction of every trajectory
        a = jnp.broadcast_to(a, (kw, *a.shape))
        s_next = agent._clip(s + ens.apply_each(agent.wm_module, params.wm, jnp.concatenate([s, a], -1)))
        return s_next, agent.trajectory_rewards(params, s_next if score_next else s, a)

    _, r = jax.lax.scan(body, jnp.broadcast_to(s0, (kw, *s0.shape)), actions)
    ret = r.sum(0)  # [Kw, K, M]
    return ret.mean(0) - agent.config.planner.scoring_lambda * ret.std(0)
