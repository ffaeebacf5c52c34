"""A 2-D point mass (s' = s + a) whose expert moves along +x and jitters in y, so its states lie in a band."""

import numpy as np


def expert_data(n_demos=40, steps=25, seed=0):
    rng = np.random.default_rng(seed)
    obs, act, nxt = [], [], []
    for _ in range(n_demos):
        s = np.array([0.0, rng.normal(0, 0.02)])
        for _ in range(steps):
            a = np.array([0.05, rng.normal(0, 0.02)])
            s2 = s + a
            obs.append(s), act.append(a), nxt.append(s2)
            s = s2
    return np.array(obs, np.float32), np.array(act, np.float32), np.array(nxt, np.float32)


def tiny_config(k=3, width=16, epochs=4, batch=64, n=12, horizon=2, sigma=0.3, top_k=3, reward="dril"):
    """A POIR config small enough to train on the point mass in seconds."""
    from poir_mjx.core.config import MLPConfig, PlannerConfig, POIRConfig, TrainConfig

    return POIRConfig(ensemble_size=k, bc=MLPConfig(layers=2, width=width), world_model=MLPConfig(layers=2, width=width),
                      train=TrainConfig(epochs=epochs, batch_size=batch, learning_rate=3e-3),
                      planner=PlannerConfig(num_trajectories=n, horizon=horizon, sigma=sigma, top_k=top_k, reward=reward))  # fmt: skip
