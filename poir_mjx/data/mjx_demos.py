"""Scripted-expert demonstrations generated in MJX: the same expert, vectorised, no robosuite needed.

One compiled rollout per (task, batch size): ``lax.scan`` over the expert's steps, ``vmap`` over
episodes sharded along the episode mesh. Episode ``k`` uses ``fold_in(PRNGKey(seed), k)``, so the
demos do not depend on the batch size. Only successful episodes are kept, each cut like a robosuite
demo (4 steps after the first success), and written in robomimic's layout with the provenance
saying MJX. ``states`` rows are [time, qpos, qvel] of the exported model (``model_file``).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from poir_mjx.cached import builder
from poir_mjx.data import expert as ex
from poir_mjx.data.robomimic import ENV_NAMES, LOW_DIM_KEYS, Demo, write_robomimic
from poir_mjx.data.expert_episodes import episode_steps
from poir_mjx.data.expert_human import expert_fns
from poir_mjx.envs.env import float_dtype, make_env, make_params
from poir_mjx.envs.tasks import CONTROL_FREQ, HORIZON, task_files
from poir_mjx.rollout.episode import Policy, batched_episodes
from poir_mjx.rollout.sharding import run_sharded
from poir_mjx.versions import mjx_version

# robosuite's demo ends this many steps after the first success (rollout.robosuite_episode).
STEPS_AFTER_SUCCESS = 4


def simulator_name() -> str:
    import mujoco

    precision = "float64" if float_dtype() == jnp.float64 else "float32"
    return f"MJX (mujoco-mjx {mjx_version()}, MuJoCo {mujoco.__version__}, jax {jax.__version__}, {precision})"


def generator_info(task: str, num: int, seed: int, sigma_init: float, style: str = "scripted") -> dict:
    return ex.generator_record(task, num, seed, sigma_init, simulator_name(), style)


def env_args(task: str, sigma_init: float) -> dict:
    """robomimic's env_args for data recorded in MJX: the robosuite task and settings the export mirrors."""
    kwargs = {
        "robots": ["Panda"],
        "controller": "OSC_POSE (BASIC composite)",
        "control_freq": CONTROL_FREQ,
        "horizon": HORIZON,
        "lite_physics": False,
        "initialization_noise": {"magnitude": sigma_init, "type": "gaussian"},
    }
    return {"env_name": ENV_NAMES[task], "type": 1, "env_version": "mjx", "simulator": simulator_name(),
            "env_kwargs": kwargs}  # fmt: skip


def expert_policy(task: str, style: str = "scripted") -> Policy:
    """The scripted expert (in `style`) as a rollout policy: its state machine is the carry, seeded by the run key."""
    init, act = expert_fns(ex.expert_task(task), style)
    return Policy(act=lambda _, e, state, k: act(state.obs, e), init=lambda _, k: init(k))


@builder
def expert_rollout(task: str, steps: int, style: str = "scripted", physics: str = "reference"):
    """jit(vmap(episode)): (unused params, keys [B], EnvParams [B]) -> (outcomes [B], per-step records [B, T, ...]),
    the MJX physics a preset of ``envs.physics`` (the demos: "reference")."""

    def record(s, a, s2):
        d = s.data
        return {"obs": s.obs, "next_obs": s2.obs, "action": a, "success": s2.success,
                "state": jnp.concatenate([d.time[None], d.qpos, d.qvel])}  # fmt: skip

    return batched_episodes(make_env(task, physics=physics), expert_policy(task, style), steps, record)


def episode_keys(seed: int, start: int, n: int) -> jax.Array:
    base = jax.random.PRNGKey(seed)
    return jax.vmap(lambda k: jax.random.fold_in(base, k))(jnp.arange(start, start + n))


def cut_demo(traj: dict, j: int, first: int, steps: int) -> Demo:
    """Episode `j` of a batch, ending STEPS_AFTER_SUCCESS steps after its first success (1-based step)."""
    t = min(first + STEPS_AFTER_SUCCESS, steps)
    obs = {k: np.asarray(traj["obs"][k][j, :t], np.float32) for k in LOW_DIM_KEYS}
    nxt = {k: np.asarray(traj["next_obs"][k][j, :t], np.float32) for k in LOW_DIM_KEYS}
    dones = np.zeros(t, np.int64)
    dones[-1] = 1
    return Demo(obs=obs, next_obs=nxt, actions=np.asarray(traj["action"][j, :t], np.float64),
                rewards=np.asarray(traj["success"][j, :t], np.float64), dones=dones,
                states=np.asarray(traj["state"][j, :t], np.float64))  # fmt: skip


def generate_mjx(task: str, num: int, seed: int, sigma_init: float, path: Path, batch: int = 16,
                 progress: bool = True, style: str = "scripted") -> dict:  # fmt: skip
    """Run the expert in batches until `num` successful episodes; write them to `path`. Returns stats."""
    from tqdm import tqdm

    steps = episode_steps(task, style)
    rollout = expert_rollout(task, steps, style)
    params = make_params(np.full(batch, sigma_init), 0.0)
    demos, lengths, tried, t0 = [], [], 0, time.perf_counter()
    bar = tqdm(total=num, desc=f"demos {task} (MJX, batch {batch})", unit="demo", disable=not progress)
    while len(demos) < num:
        res, traj = jax.tree_util.tree_map(np.asarray, run_sharded(rollout, None, episode_keys(seed, tried, batch), params))
        for j in range(batch):
            first = int(res["first_success"][j])
            if first > 0 and not res["diverged"][j] and len(demos) < num:
                demos.append(cut_demo(traj, j, first, steps))
                lengths.append(demos[-1].actions.shape[0])
                bar.update(1)
        tried += batch
        bar.set_postfix(success=f"{len(demos)}/{tried}")
        if len(demos) < num and tried >= 3 * num + 4 * batch:
            raise RuntimeError(f"{task}: the scripted expert succeeded in only {len(demos)} of {tried} MJX episodes")
    bar.close()
    model_xml = task_files(task).xml.read_text()
    for d in demos:
        d.model_file = model_xml
    info = generator_info(task, num, seed, sigma_init, style)
    stats = {**info, "episodes_tried": tried, "success_rate": len(demos) / tried,
             "length_mean": float(np.mean(lengths)), "length_min": int(np.min(lengths)),
             "length_max": int(np.max(lengths)), "seconds": time.perf_counter() - t0, "batch": batch}  # fmt: skip
    names = [f"demo_{k}" for k in range(num)]
    n_valid = max(1, num // 10)
    write_robomimic(path, demos, env_args(task, sigma_init), masks={"train": names[n_valid:], "valid": names[:n_valid]},
                    extra_attrs={"poir_mjx_generator": json.dumps(info, sort_keys=True),
                                 "poir_mjx_stats": json.dumps(stats)})  # fmt: skip
    return stats
