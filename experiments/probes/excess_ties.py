"""Probe: how often the "excess" DRIL / MOREL returns tie at the top of a planner call, and whose trajectories the
top-k then takes (run from the repository root: ``python experiments/probes/excess_ties.py``).

The excess reward is -max(d - level, 0): every candidate whose disagreement stays under the expert data's own level
scores exactly 0. The planner ranks its N trajectories in the order n = 0..N-1 (trajectory n follows head n mod K;
``core/selection.real_trajectories``) and ``lax.top_k`` breaks ties by the lower index, so a fully tied top-k is
trajectories 0..k-1: with k = K, one trajectory of every head, the head-balanced average of one sample each. For 60
random states of the default Lift demos, as recorded and with the hand moved by N(0, 5 cm) per axis, it prints the
calls whose k-th best return equals the best, and the calls whose top-k all come from one head. Needs
`results/cpu-options-lift-excess` and the seed-0 Lift agent that run used (`checkpoints/lift/`, trained on this
machine's data/demos/lift.hdf5).
"""

import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from poir_mjx.core import checkpoint  # noqa: E402
from poir_mjx.core.agent import POIR  # noqa: E402
from poir_mjx.core.selection import real_trajectories  # noqa: E402
from poir_mjx.data.robomimic import read_transitions  # noqa: E402
from poir_mjx.eval.methods import get_method  # noqa: E402
from poir_mjx.sweep.config import base_config, load_sweep_config  # noqa: E402

RUN = "results/cpu-options-lift-excess/config.json"
CHECKPOINT = "checkpoints/lift/poir-seed0-aa7d8ee0fa7dec7a.ckpt"


def main() -> None:
    stored, params, _ = checkpoint.load(CHECKPOINT)
    cfg = load_sweep_config(RUN, recorded=True)
    tr = read_transitions("data/demos/lift.hdf5", task="lift")
    rng = np.random.default_rng(0)
    idx = rng.choice(len(tr.obs), 60, replace=False)
    for method in ("POIR-DRIL", "POIR-MOREL"):
        mc = get_method(method).agent_config(base_config(cfg))
        agent = POIR(mc, stored.obs_size, stored.act_size)
        imagine, k = jax.jit(agent.imagine), mc.planner.top_k
        for shift in (0.0, 0.05):
            tied = one_head = 0
            for j, i in enumerate(idx):
                obs = np.array(tr.obs[i], np.float32)
                obs[:3] += rng.normal(0, shift, 3)  # the hand's position (eef_pos), metres
                im = imagine(params, jnp.asarray(obs), jax.random.PRNGKey(j))
                ret, _ = real_trajectories(im.returns, im.actions[0], mc.planner.num_trajectories)  # the order n
                flat = np.where(np.isnan(ret), -np.inf, np.asarray(ret))
                order = np.argsort(-flat, kind="stable")  # lax.top_k's order: ties by the lower index
                tied += flat[order[k - 1]] == flat[order[0]]
                one_head += len(set((order[:k] % im.returns.shape[0]).tolist())) == 1
            print(f"{method} excess, hand moved {shift * 100:.0f} cm: top-{k} all tied in {tied}/{len(idx)} calls, "
                  f"from one head in {one_head}/{len(idx)}")


if __name__ == "__main__":
    main()
