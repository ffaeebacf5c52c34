"""The online fine-tuning run: deploy the planner, store its transitions, retrain the world model.

One round = ``num_envs`` whole episodes collected in parallel with the current parameters (one
compiled function: ``lax.scan`` over steps, ``vmap`` over episodes, sharded over the episode mesh),
then ``updates_per_env_step x steps`` gradient steps on the expert/deployment mixture (one compiled
function). The BC prior and, for MOREL, the reward's frozen offline world model never change.

Recorded per round: the world model's one-step error on that round's transitions *before* it
trains on them (the deployment distribution, held out), next to the frozen offline model's error.
Recorded every ``eval_every`` environment steps (and at step 0, the offline model): success over
the evaluation keys. The run state is checkpointed after every round; a run started again with the
same checkpoint path continues from the last finished round and ends with identical results.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from pathlib import Path
from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from poir_mjx.core import ensemble as ens
from poir_mjx.core.agent import POIR, POIRParams, check_losses
from poir_mjx.envs.env import EnvParams
from poir_mjx.rollout.episode import batched_episodes, stateless
from poir_mjx.rollout.evaluator import success_record
from poir_mjx.rollout.sharding import replicate, run_sharded
from poir_mjx.online import buffer as rb
from poir_mjx import run_state as ock
from poir_mjx.online.finetune import deployment_error, finetune, world_model_targets


@struct.dataclass
class RunState:
    wm: ens.TrainState  # world-model parameters and optimiser state
    buffer: rb.ReplayBuffer
    key: jax.Array
    round: jax.Array  # finished rounds (environment and gradient steps follow from it)


@dataclasses.dataclass(frozen=True)
class RoundInputs:
    """What every round and evaluation of a run reads; the arrays committed to the episode mesh."""

    params: POIRParams  # the offline agent (its BC prior and reward world model never change)
    off_x: jax.Array  # expert world-model inputs [s, a] (normalised)
    off_y: jax.Array  # expert world-model targets s' - s (normalised)
    deploy: EnvParams  # the deployment noise levels, one per collection episode [num_envs]
    eval_keys: jax.Array  # one key per evaluation episode, the same at every evaluation
    eval_params: EnvParams  # the deployment noise levels, one per evaluation episode
    clip: float  # normalised states clipped to [-clip, clip] (0: no clipping)
    optimizer: Any  # the world model's optax optimiser


@dataclasses.dataclass
class OnlineResult:
    params: POIRParams  # the fine-tuned agent (world model replaced)
    curve: list[dict]  # evaluations: env_steps, successes, episodes, success_rate, ...
    rounds: list[dict]  # per round: collection success, world-model errors, loss, online fraction
    resumed_from_round: int


def make_collector(env, policy_fn, steps: int):
    """jit(vmap(episode)) -> (outcomes [B], transitions (obs, action, next_obs, valid) [B, T, .])."""

    def record(state, action, nxt):
        valid = ~state.done & ~nxt.info["diverged"]
        return env.obs_vector(state), action, env.obs_vector(nxt), valid

    return batched_episodes(env, stateless(env, policy_fn), steps, record)


@dataclasses.dataclass(frozen=True)
class OnlineTrainer:
    """Compiled pieces of an online run for one (env, agent, episode length); reuse it across cells.

    collect_in / evaluate_in: "mjx" (the compiled collector on `env`) or "robosuite" (`task` in robosuite's
    `workers` processes, eval/robosuite_eval.py): the same episode keys, the same transitions' layout.
    observation: what the agent sees in robosuite ("low_dim" or "object"; in MJX `env`'s own ``obs_vector``)."""

    env: Any
    agent: POIR
    max_steps: int
    task: str | None = None
    collect_in: str = "mjx"
    evaluate_in: str = "mjx"
    workers: int = 2
    observation: str = "low_dim"

    @functools.cached_property
    def collector(self):
        return make_collector(self.env, self.agent.plan, self.max_steps)

    @property
    def steps_per_round(self) -> int:
        return self.agent.config.online.num_envs * self.max_steps

    @property
    def num_rounds(self) -> int:
        return math.ceil(self.agent.config.online.total_env_steps / self.steps_per_round)

    @property
    def grad_steps_per_round(self) -> int:
        return max(1, round(self.agent.config.online.updates_per_env_step * self.steps_per_round))

    def counters(self, rounds) -> dict:
        """Environment and gradient steps after `rounds` finished rounds."""
        r = int(rounds)
        return {"env_steps": r * self.steps_per_round, "grad_steps": r * self.grad_steps_per_round}

    def eval_after(self, r: int) -> bool:
        """Evaluate after round r (0-based)? At the first round end past each multiple of eval_every, and at the end."""
        every = self.agent.config.online.eval_every
        before, after = r * self.steps_per_round, (r + 1) * self.steps_per_round
        return after // every > before // every or r == self.num_rounds - 1

    def init_state(self, params: POIRParams, key: jax.Array) -> RunState:
        cfg = self.agent.config
        opt = ens.make_optimizer(cfg.train)
        dtype = jax.tree_util.tree_leaves(params.wm)[0].dtype
        return RunState(
            wm=ens.init_train_state(params.wm, opt),
            buffer=rb.init(cfg.online.buffer_capacity, self.agent.obs_size, self.agent.act_size, dtype),
            key=key, round=jnp.zeros((), jnp.int32),
        )  # fmt: skip

    def run(
        self,
        params: POIRParams,
        offline: tuple[np.ndarray, np.ndarray, np.ndarray],
        env_params: EnvParams,
        eval_keys: jax.Array,
        key: jax.Array,
        *,
        checkpoint_path: str | Path | None = None,
        config_hash: str = "",
        progress: bool = False,
        on_round: Callable[[int, dict], None] | None = None,
    ) -> OnlineResult:
        """Fine-tune from the offline `params` in the deployment environment `env_params` (scalar noise levels).

        offline: the expert transitions (obs, act, next_obs) the agent was trained on.
        eval_keys: one key per evaluation episode, the same at every evaluation (paired comparison).
        """
        from tqdm import tqdm

        inputs = self._prepare(params, offline, env_params, eval_keys)
        path = Path(checkpoint_path) if checkpoint_path is not None else None
        state, curve, rounds = self._resume(path, self.init_state(params, key), config_hash)
        resumed = int(state.round)
        state = replicate(state)  # committed like the inputs: the compiled functions are not traced again in round 2
        if not curve:  # step 0: the offline model on the evaluation episodes
            curve.append(self._evaluate(inputs, state))
            self._checkpoint(path, state, config_hash, curve, rounds)
        bar = tqdm(total=self.num_rounds, initial=resumed, desc="online", unit="round", disable=not progress)
        for r in range(resumed, self.num_rounds):
            state, log = self._round(inputs, state, r)
            rounds.append(log)
            if self.eval_after(r):
                curve.append(self._evaluate(inputs, state))
            self._checkpoint(path, state, config_hash, curve, rounds)
            bar.update(1)
            bar.set_postfix(success=f"{curve[-1]['success_rate']:.2f}", wm_err=f"{log['wm_error']:.4f}",
                            offline_err=f"{log['wm_error_offline']:.4f}")  # fmt: skip
            if on_round is not None:
                on_round(r, log)
        bar.close()
        return OnlineResult(inputs.params.replace(wm=state.wm.params), curve, rounds, resumed)

    # ---- the simulators ---------------------------------------------------------------------------
    def _episodes(self, where: str, params: POIRParams, keys: jax.Array, env_params: EnvParams, record: bool):
        """(outcome, transitions (obs, action, next_obs, valid) [B, T, .] or None) of one episode per key."""
        if where == "mjx":
            out, trans = run_sharded(self.collector, params, keys, env_params)
            return out, trans
        from poir_mjx.eval import robosuite_eval

        run = robosuite_eval.collect if record else robosuite_eval.evaluate
        res = run(self.task, self.agent.plan, params, keys, np.asarray(env_params.sigma_init),
                  np.asarray(env_params.sigma_action), self.max_steps, self.workers, progress=False,
                  observation=self.observation)  # fmt: skip
        if not record:
            return res, None
        out, trans = res
        if trans is None:  # every episode ended at its reset: nothing to learn from
            b, t, do, da = keys.shape[0], self.max_steps, self.agent.obs_size, self.agent.act_size
            trans = (np.zeros((b, t, do)), np.zeros((b, t, da)), np.zeros((b, t, do)), np.zeros((b, t), bool))
        dtype = jax.tree_util.tree_leaves(params.wm)[0].dtype
        return out, tuple(jnp.asarray(x, bool if i == 3 else dtype) for i, x in enumerate(trans))

    # ---- the steps of a run ----------------------------------------------------------------------
    def _prepare(self, params: POIRParams, offline, env_params: EnvParams, eval_keys: jax.Array) -> RoundInputs:
        """Check the agent and data, build the expert world-model targets, broadcast the noise levels."""
        agent = self.agent
        if params.wm is None:
            raise ValueError("params.wm: online fine-tuning needs a world model (a 'poir' agent)")
        opt = ens.make_optimizer(agent.config.train)
        obs, act, nxt = (jnp.asarray(a, jax.tree_util.tree_leaves(params.wm)[0].dtype) for a in offline)
        clip = agent.config.normalizer.clip if agent.config.normalize else 0.0
        off_x, off_y = world_model_targets(params.obs_norm, params.act_norm, obs, act, nxt, clip)
        batch = agent.config.train.batch_size
        if off_x.shape[0] < batch:
            raise ValueError(f"batch_size: {batch} exceeds the {off_x.shape[0]} offline transitions")

        def per_episode(n):
            return jax.tree_util.tree_map(lambda x: jnp.broadcast_to(jnp.asarray(x), (n,)), env_params)

        params, off_x, off_y = replicate((params, off_x, off_y))
        return RoundInputs(params, off_x, off_y, per_episode(agent.config.online.num_envs),
                           eval_keys, per_episode(eval_keys.shape[0]), clip, opt)  # fmt: skip

    def _resume(self, path: Path | None, fresh: RunState, config_hash: str) -> tuple[RunState, list, list]:
        """(run state, curve, rounds): from the checkpoint at `path` if there is one, else `fresh` and empty records."""
        if path is not None and path.exists():
            state, meta = ock.load(path, fresh, config_hash)
            return state, meta["curve"], meta["rounds"]
        return fresh, [], []

    def _checkpoint(self, path: Path | None, state: RunState, config_hash: str, curve: list, rounds: list) -> None:
        if path is not None:
            ock.save(path, state, {"config_hash": config_hash, "curve": curve, "rounds": rounds})

    def _evaluate(self, inputs: RoundInputs, st: RunState) -> dict:
        """Success of the current world model over the evaluation episodes (the same keys every time)."""
        t0 = time.perf_counter()
        # the collector again (its transitions unused): one compilation when num_envs == the evaluation episodes
        cur = inputs.params.replace(wm=st.wm.params)
        res, _ = self._episodes(self.evaluate_in, cur, inputs.eval_keys, inputs.eval_params, record=False)
        return {**self.counters(st.round), **success_record(res, time.perf_counter() - t0)}

    def _round(self, inputs: RoundInputs, state: RunState, r: int) -> tuple[RunState, dict]:
        """Round r (0-based): collect num_envs episodes, measure both world models on them, store them, train."""
        t0 = time.perf_counter()
        agent, params, clip = self.agent, inputs.params, inputs.clip
        key, k_collect, k_train = jax.random.split(state.key, 3)
        cur = params.replace(wm=state.wm.params)
        n = agent.config.online.num_envs
        outcome, (o, a, o2, v) = self._episodes(self.collect_in, cur, jax.random.split(k_collect, n), inputs.deploy,
                                                record=True)  # fmt: skip
        t_collect = time.perf_counter() - t0
        flat = [x.reshape((-1,) + x.shape[2:]) for x in (o, a, o2, v)]
        err_now = deployment_error(agent.wm_module, state.wm.params, params.obs_norm, params.act_norm, *flat, clip)
        err_off = deployment_error(agent.wm_module, params.reward_wm, params.obs_norm, params.act_norm, *flat, clip)
        buf = rb.add(state.buffer, *flat)
        batch = agent.config.train.batch_size
        wm, losses, frac = finetune(agent.train_modules[1], inputs.optimizer, agent.config.online, batch,
                                    self.grad_steps_per_round, state.wm, inputs.off_x, inputs.off_y, buf,
                                    params.obs_norm, params.act_norm, state.round * self.grad_steps_per_round,
                                    k_train, clip)  # fmt: skip
        check_losses({"loss": losses}, f"online fine-tuning, round {r + 1}", "train.learning_rate")
        state = RunState(wm=wm, buffer=buf, key=key, round=state.round + 1)
        first = np.asarray(outcome["first_success"])
        log = {
            "round": r + 1, **self.counters(state.round),
            "collect_success_rate": float((first >= 0).mean()),
            "valid_transitions": int(np.asarray(v).sum()),
            "wm_error": float(np.mean(err_now)), "wm_error_offline": float(np.mean(err_off)),
            "loss_last": float(np.mean(losses[-1])), "online_fraction": float(frac),
            "collect_s": t_collect, "wall_s": time.perf_counter() - t0,
        }  # fmt: skip
        return state, log
