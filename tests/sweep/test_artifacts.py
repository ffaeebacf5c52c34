"""Trained agents the sweep reuses: a raw-space POIR prior takes EBC's heads from EBC's checkpoint."""

import jax
import numpy as np

from poir_mjx.core.agent import POIR
from poir_mjx.data.robomimic import write_robomimic
from poir_mjx.eval.methods import get_method
from poir_mjx.sweep.artifacts import demos_for, train_or_load
from poir_mjx.sweep.config import SweepConfig
from tests.helpers import ENV_ARGS, make_demo

TINY = {"train.epochs": 2, "train.batch_size": 16, "ensemble_size": 2, "bc.width": 16, "world_model.width": 16}


def test_poir_with_ebcs_checkpoint_equals_poir_trained_alone(tmp_path, monkeypatch):
    """With EBC's checkpoint there (same config, seed, data) POIR skips training its raw-space heads and comes out
    bit for bit the agent it trains alone, world model and expert levels included."""
    demos = write_robomimic(tmp_path / "d.hdf5", [make_demo(30, 0), make_demo(25, 1)], ENV_ARGS)
    cfg = SweepConfig(name="t", tasks=("lift",), methods=("EBC", "POIR-DRIL"), demo_files={"lift": str(demos)},
                      overrides=TINY)  # fmt: skip
    tr, prov = demos_for(cfg, "lift", tmp_path / "data", progress=False)
    given, fit = [], POIR.fit
    monkeypatch.setattr(POIR, "fit", lambda self, *a, **kw: given.append(kw.get("bc_params") is not None) or
                        fit(self, *a, **kw))  # fmt: skip
    alone = train_or_load(get_method("POIR-DRIL"), cfg, "lift", 0, tr, prov, tmp_path / "a", progress=False)
    ebc = train_or_load(get_method("EBC"), cfg, "lift", 0, tr, prov, tmp_path / "b", progress=False)
    reused = train_or_load(get_method("POIR-DRIL"), cfg, "lift", 0, tr, prov, tmp_path / "b", progress=False)
    assert given == [False, False, True]  # POIR alone trains its heads; EBC's are there for the second POIR
    assert alone[2].name == reused[2].name  # the same checkpoint key
    for a, b in zip(jax.tree_util.tree_leaves(alone[1]), jax.tree_util.tree_leaves(reused[1]), strict=True):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(jax.tree_util.tree_leaves(ebc[1].bc), jax.tree_util.tree_leaves(reused[1].bc), strict=True):
        np.testing.assert_array_equal(a, b)
