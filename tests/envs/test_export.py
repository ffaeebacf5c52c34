"""`make envs` is deterministic and matches the committed files; the exported models load in MJX."""

import json
import shutil

import mujoco
import pytest

from poir_mjx.envs import export
from poir_mjx.envs.env import load_model
from poir_mjx.envs.tasks import TASKS, UnknownTaskError, task_files


@pytest.mark.needs_robosuite
@pytest.mark.parametrize("task", TASKS)
def test_export_is_byte_identical_to_committed_files(task):
    xml, meta = export.export_task(task)
    files = task_files(task)
    assert xml == files.xml.read_text(), f"{files.xml} differs from a fresh export: run `make envs`"
    assert meta == files.meta.read_text(), f"{files.meta} differs from a fresh export: run `make envs`"


@pytest.mark.needs_robosuite
def test_shipped_assets_are_robosuites_files():
    xmls = [task_files(t).xml.read_text() for t in TASKS]
    shipped = export.asset_files(xmls)
    assert "assets/grippers/meshes/panda_gripper/finger.stl" in shipped
    assert "MIT License" in shipped["assets/LICENSE-robosuite"].decode()
    for rel, data in shipped.items():
        f = task_files("lift").xml.parent / rel
        assert f.read_bytes() == data, f"{f} differs from robosuite's file: run `make envs`"


@pytest.mark.parametrize("task", TASKS)
def test_exported_model_is_lean_and_keeps_robosuite_solver(task):
    model, meta = load_model(task)
    assert model.opt.timestep == pytest.approx(0.002)
    assert meta["substeps"] == 25
    assert model.opt.iterations == 100 and model.opt.ls_iterations == 50
    assert model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC and model.opt.impratio == pytest.approx(20)
    # No colliding cylinder (MJX cannot collide them with boxes/meshes), no arm-link collision meshes.
    for g in range(model.ngeom):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
        assert model.geom_type[g] != mujoco.mjtGeom.mjGEOM_CYLINDER, name
        assert not name.startswith("robot0_link"), name
    # One free object left (the task's), plus 7 arm and 2 finger joints.
    assert model.nq == 7 + 2 + 7, model.nq
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, meta["object_body"]) >= 0


def test_unknown_task_is_a_clear_error():
    with pytest.raises(UnknownTaskError, match="task: unknown task 'Lift'"):
        task_files("Lift")


def test_broken_metadata_names_the_file(tmp_path):
    shutil.copytree(task_files("lift").xml.parent / "assets", tmp_path / "assets")
    for task in ("lift",):
        f = task_files(task)
        (tmp_path / f.xml.name).write_text(f.xml.read_text())
        meta = json.loads(f.meta.read_text())
        meta["task"] = "pick_place_can"
        (tmp_path / f.meta.name).write_text(json.dumps(meta))
        with pytest.raises(ValueError, match=r"lift\.json: field 'task'"):
            load_model(task, tmp_path)
    with pytest.raises(ValueError, match=r"pick_place_can\.xml: missing"):
        load_model("pick_place_can", tmp_path)
