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
