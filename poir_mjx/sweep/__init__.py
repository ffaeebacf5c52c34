"""Noise sweeps over (task, method, sigma_init, sigma_action, seed): the config, the plan, the cell runners, the
records and the tables (``run.run_sweep`` is the entry point; ``compare`` reads several runs into one table)."""
