"""The four online imitation baselines by name: their configs (presets plus overrides) and learners.

Each algorithm's module defines a frozen ``Config`` (documented fields), ``PRESETS`` {"paper", "cpu-small"} and a learner
class ``(env, config, obs_size, act_size)`` implementing ``learner.Learner``. The sweep's ``preset`` picks the preset; a
sweep's ``baseline_overrides`` {method: {dotted field: value}} replaces fields.
"""

from __future__ import annotations

import dataclasses
import importlib

from poir_mjx.core.config import ConfigError, apply_overrides


@dataclasses.dataclass(frozen=True)
class Baseline:
    name: str
    module: str  # poir_mjx.baselines.<module>
    learner: str  # the learner class in it
    description: str

    def _mod(self):
        return importlib.import_module(f"poir_mjx.baselines.{self.module}")

    def config(self, preset: str, overrides: dict | None = None, source: str = "baseline_overrides"):
        presets = self._mod().PRESETS
        if preset not in presets:
            raise ConfigError(f"preset: {self.name} has no preset {preset!r}; expected one of {sorted(presets)}")
        cfg = presets[preset]
        if overrides:
            cfg = apply_overrides(cfg, overrides, f"{source}.{self.name}")
        try:
            (cfg.validate if hasattr(cfg, "validate") else cfg.check)()
        except (ConfigError, ValueError) as e:
            raise ConfigError(f"{source}.{self.name}: {e}") from None
        return cfg

    def make(self, env, cfg, obs_size: int, act_size: int):
        cls = getattr(self._mod(), self.learner)
        if self.module == "ppo_dril":  # sizes come from the expert data at init
            return cls(env, cfg)
        return cls(env, cfg, obs_size, act_size)

    @staticmethod
    def schedule(cfg) -> tuple[int, int]:
        """(total_env_steps, eval_every): top-level fields, or those of the config's ``loop`` (the off-policy ones)."""
        src = getattr(cfg, "loop", cfg)
        return src.total_env_steps, src.eval_every


BASELINES: dict[str, Baseline] = {
    b.name: b
    for b in (
        Baseline("DAC", "dac", "DAC", "adversarial imitation on SAC with absorbing states (Kostrikov et al. 2019)"),
        Baseline("ValueDICE", "valuedice", "ValueDICE", "off-policy distribution matching (Kostrikov et al. 2020)"),
        Baseline("SQIL", "sqil", "SQIL", "SAC with reward 1 on expert and 0 on agent transitions (Reddy et al. 2020)"),
        Baseline("PPO+DRIL", "ppo_dril", "PPODRIL", "PPO on the DRIL reward, BC-ensemble disagreement (Brantley et al. 2020)"),
    )
}


def get_baseline(name: str) -> Baseline:
    if name not in BASELINES:
        raise ConfigError(f"method: unknown baseline {name!r}; expected one of {', '.join(BASELINES)}")
    return BASELINES[name]
