"""How far a run's planner moves its executed action from EBC's (the prior's head mean) at the demo states.

    .venv/bin/python experiments/probes/planner_dither.py results/cpu-prior-human-demos 0

For POIR-random and POIR-DRIL of the run's agent (training seed as the second argument), at every 4th of the first
200 expert states, the planner is called with 16 keys; printed per action dimension (robosuite's units): the RMS of
(planned action - EBC's action), and the planned action's spread over the keys. issue 41 used it to size the action
noise of the EBC control on the human-like demos (docs/diagnose.md).
"""

import sys

import jax
import numpy as np

from poir_mjx.sweep.artifacts import load_run_agent


def main(run: str, seed: int) -> None:
    for method in ("POIR-random", "POIR-DRIL"):
        agent, params, _ = load_run_agent(run, "lift", method, seed=seed, progress=False)
        obs = np.asarray(params.obs_norm.inverse(params.expert_states[:200:4]))
        plan = jax.jit(jax.vmap(jax.vmap(lambda o, k: agent.plan(params, o, k), (None, 0)), (0, None)))
        ebc = jax.jit(jax.vmap(lambda o: agent.ebc_action(params, o)))
        keys = jax.random.split(jax.random.PRNGKey(0), 16)
        a, e = np.asarray(plan(obs, keys)), np.asarray(ebc(obs))
        print(f"{method} ({run}, seed {seed}, {len(obs)} states x {len(keys)} keys)")
        print("  RMS(plan - EBC) per dimension:", np.sqrt(((a - e[:, None]) ** 2).mean((0, 1))).round(4))
        print("  spread of the plan over keys:  ", a.std(1).mean(0).round(4))


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 0)
