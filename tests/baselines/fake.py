"""A learner whose progress is known in advance, for the run loop and the sweep's baseline cells."""

import dataclasses

import jax
import jax.numpy as jnp


@dataclasses.dataclass(frozen=True)
class StepLearner:
    """Its policy moves x by `speed` a step; every iteration adds 0.01 to the speed (a 30-step episode succeeds
    once speed >= 1/30)."""

    num_envs: int = 4
    name: str = "step-learner"
    env_steps_per_iteration: int = 4

    def init(self, key, expert, env_params):
        return {"speed": jnp.float32(0.0), "env_steps": jnp.int32(0), "key": key}

    def train(self, state, iterations):
        return jax.jit(lambda s: ({**s, "speed": s["speed"] + 0.01 * iterations,
                                   "env_steps": s["env_steps"] + self.num_envs * iterations},
                                  {"imitation_reward": jnp.full(iterations, s["speed"])}))(state)  # fmt: skip

    def env_steps(self, state):
        return state["env_steps"]

    def policy_params(self, state):
        return state["speed"]

    def policy_fn(self):
        return lambda speed, obs, key: jnp.array([speed, -obs[1]])
