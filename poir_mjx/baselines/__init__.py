"""The paper's online imitation baselines (DAC, ValueDICE, SQIL, PPO+DRIL), trained in the cell's perturbed MJX env."""
