"""The environment's physics settings (poir_mjx/envs/physics.py): presets reach the MJX model, bad values are
one clear error. No physics is stepped here (nothing compiled)."""

import dataclasses

import numpy as np
import pytest

from poir_mjx.envs.env import make_env
from poir_mjx.envs.physics import PHYSICS_PRESETS, REFERENCE, PhysicsConfig, physics_preset
from poir_mjx.typed_config import ConfigError


def test_reference_is_todays_physics_and_the_default():
    assert REFERENCE == PhysicsConfig() == physics_preset("reference")
    env = make_env("lift")
    assert env.physics == REFERENCE
    opt = env.model.opt
    assert (opt.iterations, opt.ls_iterations) == (100, 50)
    np.testing.assert_allclose(float(opt.tolerance), 1e-8, rtol=1e-6)
    assert make_env("lift", physics="reference") is env  # one environment per task, precision and physics


def test_fast_preset_reaches_the_mjx_model_and_every_size_variant():
    fast = physics_preset("fast")
    assert (fast.iterations, fast.ls_iterations) == (10, 8)
    assert (fast.linesearch_loop, fast.cone_hessian, fast.floor_contacts) == ("while", "blocks", False)
    env = make_env("lift", physics="fast")
    assert env.physics == fast
    assert (env.mj_model.opt.iterations, env.mj_model.opt.ls_iterations) == (10, 8)
    for m in (env.model, env.variants.model(0), env.variants.model(5)):
        assert (m.opt.iterations, m.opt.ls_iterations) == (10, 8)
    assert make_env("lift").model.opt.iterations == 100  # the reference is untouched
    # same-maths is fast at the reference's iteration budget: the two differ by that budget alone
    assert physics_preset("same-maths") == dataclasses.replace(fast, iterations=100, ls_iterations=50)


def test_each_field_reaches_the_model_on_its_own():
    cfg = dataclasses.replace(REFERENCE, iterations=7, ls_iterations=3, tolerance=1e-6)
    m = make_env("pick_place_can", physics=cfg).model
    assert (m.opt.iterations, m.opt.ls_iterations) == (7, 3)
    np.testing.assert_allclose(float(m.opt.tolerance), 1e-6, rtol=1e-6)


def test_bad_physics_is_one_error_naming_the_field():
    with pytest.raises(ConfigError, match="physics.iterations: must be positive"):
        make_env("lift", physics=PhysicsConfig(iterations=0))
    with pytest.raises(ConfigError, match="physics.tolerance: must be >= 0"):
        make_env("lift", physics=PhysicsConfig(tolerance=-1.0))
    with pytest.raises(ConfigError, match="unknown preset 'fastest'"):
        make_env("lift", physics="fastest")
    with pytest.raises(ConfigError, match="physics.max_contact_points: must be positive"):
        make_env("lift", physics=PhysicsConfig(max_contact_points=0))
    with pytest.raises(ConfigError, match=r"physics.max_contact_points: must be in \[-1"):
        make_env("lift", physics=PhysicsConfig(max_contact_points=-2))
    assert set(PHYSICS_PRESETS) == {"reference", "same-maths", "fast", "fast-capped", "warp"}


def test_warp_settings_are_checked_before_anything_is_built():
    with pytest.raises(ConfigError, match="physics.impl: 'warp' runs MuJoCo Warp's own solver"):
        make_env("lift", physics=PhysicsConfig(impl="warp", linesearch_loop="while"))
    with pytest.raises(ConfigError, match="physics.warp_contacts: sizes MuJoCo Warp's buffers"):
        make_env("lift", physics=PhysicsConfig(warp_contacts=16))
    with pytest.raises(ConfigError, match="physics.warp_contacts: must be >= 0"):
        make_env("lift", physics=PhysicsConfig(impl="warp", warp_contacts=-1))


def test_warp_where_it_is_missing_is_one_error_naming_the_field():
    from poir_mjx.optional import warp_installed

    if warp_installed():
        pytest.skip("MuJoCo Warp is installed here (tests/envs/test_warp.py runs it)")
    with pytest.raises(ConfigError, match=r"physics.impl: 'warp' needs mujoco-mjx 3.17 or newer with warp-lang"):
        make_env("lift", physics="warp")


@pytest.mark.parametrize("task, uncapped, capped", [("lift", 56, 56), ("pick_place_can", 320, 64),
                                                    ("nut_assembly_square", 232, 64)])  # fmt: skip
def test_contact_cap_bounds_the_contacts_per_dimension_group(task, uncapped, capped):
    """fast-capped is fast with at most 32 contacts per contact-dimension group (condim 3 and 4 here): PickPlaceCan's
    and Square's constraint rows shrink 4-5x, Lift's groups are under the cap and keep every contact."""
    from mujoco import mjx

    fast, cap = make_env(task, physics="fast"), make_env(task, physics="fast-capped")
    assert physics_preset("fast-capped") == dataclasses.replace(physics_preset("fast"), max_contact_points=32)
    n_fast, n_cap = mjx.make_data(fast.mj_model)._impl.ncon, mjx.make_data(cap.mj_model)._impl.ncon
    assert (n_fast, n_cap) == (uncapped, capped)
    assert mjx.make_data(cap.model)._impl.ncon == capped  # the MJX model the env steps, not only the C model
    assert cap.mj_model.ngeom == fast.mj_model.ngeom  # no geom or pair removed: only the contacts kept per step


@pytest.mark.parametrize("task, floor_pairs", [("lift", 6), ("pick_place_can", 6), ("nut_assembly_square", 10)])
def test_floor_contacts_off_drops_exactly_the_floor_pairs(task, floor_pairs):
    import mujoco
    from mujoco.mjx._src.collision_driver import geom_pairs

    def pairs(m):
        return {(int(a), int(b)) for a, b, _ in geom_pairs(m)}

    ref, off = make_env(task).mj_model, make_env(task, physics=PhysicsConfig(floor_contacts=False)).mj_model
    floor = mujoco.mj_name2id(ref, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    dropped = pairs(ref) - pairs(off)
    assert len(dropped) == floor_pairs and all(floor in p for p in dropped)
    assert pairs(off) < pairs(ref)
    gripper = {g for p in dropped for g in p if mujoco.mj_id2name(ref, mujoco.mjtObj.mjOBJ_GEOM, g).startswith("gripper0_")}
    assert len(gripper) == 5  # hand box, two finger meshes, two pads; the rest are the object's geoms
    assert off.ngeom == ref.ngeom and off.nbody == ref.nbody  # nothing else in the model changes
