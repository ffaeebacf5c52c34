"""The policy's observation layout (robomimic's low-dim keys, or the object-state vector alone), each dimension's
physical kind, the action size."""

from __future__ import annotations

import json
from pathlib import Path

from poir_mjx.envs.tasks import task_files

# Robot part of the layout: key, size, group (the object's keys come from the task's metadata).
ROBOT_OBS = (("robot0_eef_pos", 3, "position"), ("robot0_eef_quat", 4, "quaternion"),
             ("robot0_gripper_qpos", 2, "gripper"))  # fmt: skip
ROBOT_OBS_SIZE = sum(n for _, n, _ in ROBOT_OBS)
# robomimic's low-dim observation keys in the order the policy's vector concatenates them (object last).
OBS_KEYS = tuple(k for k, _, _ in ROBOT_OBS) + ("object",)
# What the networks and rewards see: robomimic's low-dim set (hand pose, fingers, object-state), or robosuite's
# object-state vector alone (object pose and object-to-gripper offset: 10 numbers for Lift, 14 for Can and Square),
# the paper's observation. The environments always keep every key (the scripted expert reads the hand's).
OBSERVATIONS = {"low_dim": OBS_KEYS, "object": ("object",)}
# OSC_POSE's action: position delta (3), axis-angle delta (3), gripper (1).
ACTION_SIZE = 7


def obs_sizes(meta: dict) -> dict[str, int]:
    """Each observation key's size for the task described by `meta` (the object's from its metadata)."""
    return {**{k: n for k, n, _ in ROBOT_OBS}, "object": meta["object_obs_size"]}


def observation_keys(observation: str) -> tuple[str, ...]:
    """The keys the policy's vector concatenates for `observation` ("low_dim" or "object")."""
    if observation not in OBSERVATIONS:
        raise ValueError(f"observation: {observation!r} is not one of {list(OBSERVATIONS)}")
    return OBSERVATIONS[observation]


def observation_named(keys) -> str | None:
    """The observation whose keys are `keys` (a checkpoint's recorded "obs_keys"), None if no observation has them."""
    return next((name for name, k in OBSERVATIONS.items() if list(k) == list(keys)), None)


def object_key_group(key: str) -> tuple[int, str]:
    """(size, group) of one of robosuite's object observables, e.g. cube_pos, Can_to_robot0_eef_quat."""
    if key.endswith("_quat"):
        return 4, "quaternion"
    if key.endswith("_pos"):
        return 3, "position"
    raise ValueError(f"object observation key {key!r} is not supported")


def obs_groups_from_meta(meta: dict, keys=OBS_KEYS) -> tuple[str, ...]:
    """One group name per dimension of the flat observation of `keys`: "position", "quaternion" or "gripper"."""
    per_key = {k: [g] * n for k, n, g in ROBOT_OBS}
    per_key["object"] = []
    for key in meta["object_obs_keys"]:
        n, g = object_key_group(key)
        per_key["object"] += [g] * n
    if len(per_key["object"]) != meta["object_obs_size"]:
        raise ValueError(f"object_obs_keys: sizes add up to {len(per_key['object'])}, "
                         f"not object_obs_size {meta['object_obs_size']}")
    return tuple(g for k in keys for g in per_key[k])


def obs_groups(task: str, envs_dir: str | Path | None = None, observation: str = "low_dim") -> tuple[str, ...]:
    """The groups of `task`'s `observation` ("low_dim" or "object"), read from envs/<task>.json (no model
    compilation)."""
    return obs_groups_from_meta(json.loads(task_files(task, envs_dir).meta.read_text()), observation_keys(observation))
