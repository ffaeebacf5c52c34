"""The expert's human_like style (poir_mjx/data/expert_human.py): it varies what the scripted expert holds fixed, the
scripted expert is untouched by it, and the same key gives the same episode on the robosuite path and in MJX's
vmapped rollout. On the kinematic stand-in (tests/data/expert_toy.py): no physics, seconds."""

import hashlib
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from poir_mjx.data import expert as ex
from poir_mjx.data import mjx_demos
from poir_mjx.data.demos import demo_path
from tests.data import expert_toy

# The scripted expert's actions on the stand-in, rounded to 1e-6, as they were before the styles existed (commit
# facbb3c): sha256 of the float64 bytes, first 16 hex digits, per episode key.
SCRIPTED_DIGESTS = {0: "f98df2aa055ef299", 7: "4b4bcbdc52d9edac"}
SEEDS = range(8)


def digest(actions: np.ndarray) -> str:
    return hashlib.sha256((np.round(actions.astype(np.float64), 6) + 0.0).tobytes()).hexdigest()[:16]


def switches(actions):
    return int((np.diff(np.sign(actions[:, 6])) != 0).sum())


def first_close(actions):
    return int(np.argmax(actions[:, 6] > 0))


def test_scripted_actions_are_bit_for_bit_what_they_were():
    for seed, want in SCRIPTED_DIGESTS.items():
        assert digest(expert_toy.run(seed)[0]) == want, seed


def test_human_like_varies_rotation_speed_pauses_path_and_grasps():
    scripted = [expert_toy.run(s, steps=150)[0] for s in SEEDS]
    human = [expert_toy.run(s, steps=150, style="human_like")[0] for s in SEEDS]
    # Rotation: the stand-in's hand points straight down, so the scripted tilt actions are exactly 0.
    assert all(np.all(a[:, 3:5] == 0) for a in scripted)
    assert all(np.all(a[:, 3:6].std(0) > 0.005) for a in human)
    # Time to the (first) close: spread wider, and longer on average (pauses, detours).
    s_close, h_close = [first_close(a) for a in scripted], [first_close(a) for a in human]
    assert np.std(h_close) > 2 * np.std(s_close) and np.mean(h_close) > np.mean(s_close)
    # A pause: three or more steps of near-still position actions before the close, which the scripted never does.
    def still(a):  # the longest run of near-still position actions before the close
        quiet = np.abs(a[: first_close(a), :3]).max(1) < 0.08
        return np.convolve(quiet, np.ones(3), "valid").max(initial=0)

    assert max(still(a) for a in scripted) < 3 and any(still(a) >= 3 for a in human)
    # A re-grasp (close, open, close) in some episode, never in the scripted ones.
    assert all(switches(a) == 1 for a in scripted) and any(switches(a) >= 3 for a in human)
    # The approach path: the first actions point elsewhere than the scripted twin's in most episodes.
    cos = [a[0, :2] @ b[0, :2] / (np.linalg.norm(a[0, :2]) * np.linalg.norm(b[0, :2]) + 1e-9)
           for a, b in zip(scripted, human)]  # fmt: skip
    assert sum(c < 0.97 for c in cos) >= 3


def test_the_same_key_gives_the_same_episode_on_the_robosuite_path_and_in_the_mjx_rollout():
    """The robosuite recorder's jitted init/act and MJX's vmapped rollout policy, fed the same observations with the
    same key: the same style draws and the same actions."""
    seed, steps = 7, 60
    acts, seen = expert_toy.run(seed, steps=steps, style="human_like")
    policy = mjx_demos.expert_policy("lift", "human_like")
    keys = jnp.stack([jax.random.PRNGKey(seed), jax.random.PRNGKey(seed + 1)])  # a batch, as the rollout has
    carry = jax.vmap(lambda k: policy.init(None, k))(keys)
    from poir_mjx.data.expert_episodes import _jit_expert

    one = _jit_expert("lift", "human_like")[0](jax.random.PRNGKey(seed))
    for f in ("seg_gain", "rot_sigma", "pause_len", "via_on", "via_lateral", "regrasp"):
        np.testing.assert_array_equal(np.asarray(getattr(carry, f))[0], np.asarray(getattr(one, f)), err_msg=f)

    class State:  # what the rollout policy reads of the environment's state
        def __init__(self, obs):
            self.obs = obs

    def episode(c, observations):  # lax.scan over the steps, as the rollout's carry goes
        return jax.lax.scan(lambda c, o: policy.act(None, c, State(o), None)[::-1], c, observations)[1]

    observations = {k: jnp.stack([o[k] for o in seen]) for k in seen[0]}
    out = np.asarray(jax.jit(jax.vmap(episode, in_axes=(0, None)))(carry, observations))[0]
    np.testing.assert_allclose(out, acts, atol=1e-5)
    np.testing.assert_array_equal(out[:, 6], acts[:, 6])


def test_the_record_and_file_name_name_the_style_and_the_scripted_ones_are_unchanged():
    old = {"expert": "poir-mjx scripted expert v1", "simulator": "sim", "task": "lift", "num_demos": 200, "seed": 0,
           "sigma_init": 0.02, "sigma_action": 0.0}  # fmt: skip
    assert ex.generator_record("lift", 200, 0, 0.02, "sim") == old
    assert ex.generator_record("lift", 200, 0, 0.02, "sim", "human_like") == {**old, "demo_style": "human_like"}
    assert demo_path("lift", Path("d")) == Path("d/lift.hdf5")
    assert demo_path("lift", Path("d"), "mjx", 16) == Path("d/lift-mjx-n16.hdf5")
    assert demo_path("lift", Path("d"), style="human_like") == Path("d/lift-human.hdf5")
    assert demo_path("lift", Path("d"), "mjx", 16, "human_like") == Path("d/lift-mjx-human-n16.hdf5")
    with pytest.raises(ValueError, match="demo style"):
        from poir_mjx.data.expert_human import expert_fns

        expert_fns(ex.expert_task("lift"), "robotic")
