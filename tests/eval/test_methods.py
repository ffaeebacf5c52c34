"""The method registry (poir_mjx/eval/methods.py): names, the agents they need, how they act."""

import dataclasses

import pytest

from poir_mjx.core.config import OnlineConfig, preset
from poir_mjx.eval.methods import METHODS, UnknownMethodError, get_method

BASE = dataclasses.replace(preset("cpu-small"), online=dataclasses.replace(preset("cpu-small").online, num_envs=3))


def test_registry_names_and_unknown_method():
    assert set(METHODS) == {"BC", "EBC", "POIR-L2", "POIR-DRIL", "POIR-MOREL", "POIR-noprior", "POIR-prior", "POIR-random",
                            "POIR-L2 oracle", "POIR-DRIL oracle",
                            "POIR-L2 online", "POIR-DRIL online", "POIR-MOREL online",
                            "DAC", "ValueDICE", "SQIL", "PPO+DRIL"}  # fmt: skip
    assert {n for n, m in METHODS.items() if m.is_baseline} == {"DAC", "ValueDICE", "SQIL", "PPO+DRIL"}
    assert all(METHODS[n].has_curve for n in METHODS if METHODS[n].is_baseline or METHODS[n].online)
    assert not any(METHODS[n].has_curve for n in ("BC", "EBC", "POIR-DRIL"))
    m = get_method("POIR-MOREL online")
    assert m.online and m.reward == "morel" and m.agent_kind == "poir" and m.act == "plan"
    with pytest.raises(UnknownMethodError, match="method: unknown method 'GAIL'; expected one of BC, EBC"):
        get_method("GAIL")


@pytest.mark.parametrize("name, normalize, reward, use_prior", [
    ("BC", False, "dril", True), ("EBC", False, "dril", True),
    ("POIR-L2", True, "l2", True), ("POIR-MOREL", True, "morel", True), ("POIR-noprior", True, "dril", False),
    ("POIR-DRIL online", True, "dril", True), ("POIR-prior", True, "dril", True), ("POIR-random", True, "dril", True),
])  # fmt: skip
def test_agent_config_sets_normalisation_and_planner(name, normalize, reward, use_prior):
    m = get_method(name)
    cfg = m.agent_config(BASE)
    assert (cfg.normalize, cfg.planner.reward, cfg.planner.use_prior) == (normalize, reward, use_prior)
    # only online methods keep the online settings; everything else is the base config's
    assert cfg.online == (BASE.online if m.online else OnlineConfig())
    assert (cfg.bc, cfg.world_model, cfg.train) == (BASE.bc, BASE.world_model, BASE.train)


def test_poir_variants_share_one_offline_agent_and_policies_another():
    poir = {get_method(n).training_config(BASE) for n in METHODS if METHODS[n].agent_kind == "poir"}
    policy = {get_method(n).training_config(BASE) for n in ("BC", "EBC")}
    assert len(poir) == 1 and len(policy) == 1 and poir != policy
    other_online = dataclasses.replace(BASE, online=OnlineConfig())
    assert get_method("POIR-DRIL online").training_config(BASE) == get_method("POIR-DRIL").training_config(other_online)


class _FakeAgent:
    def bc_action(self, p, o):
        return ("bc", p, o)

    def ebc_action(self, p, o):
        return ("ebc", p, o)

    def plan(self, p, o, k):
        return ("plan", p, o, k)


def test_controls_use_the_poir_agent_and_only_change_how_it_acts():
    prior, rand = get_method("POIR-prior"), get_method("POIR-random")
    assert prior.agent_kind == rand.agent_kind == "poir" and prior.act == "ebc" and rand.act == "plan"
    assert rand.agent_config(BASE).planner.selection == "random"
    assert get_method("POIR-DRIL").agent_config(BASE).planner.selection == "top_k"
    assert rand.training_config(BASE) == prior.training_config(BASE) == get_method("POIR-DRIL").training_config(BASE)
    excess = dataclasses.replace(BASE, planner=dataclasses.replace(BASE.planner, disagreement="excess"))
    assert get_method("POIR-DRIL").training_config(excess) == get_method("POIR-DRIL").training_config(BASE)
    assert get_method("POIR-DRIL").agent_config(excess).planner.disagreement == "excess"


@pytest.mark.parametrize("name, expect", [
    ("BC", ("bc", "P", "O")), ("EBC", ("ebc", "P", "O")), ("POIR-prior", ("ebc", "P", "O")),
    ("POIR-DRIL", ("plan", "P", "O", "K")), ("POIR-L2 online", ("plan", "P", "O", "K")),
])  # fmt: skip
def test_policy_fn_calls_the_methods_action(name, expect):
    assert get_method(name).policy_fn(_FakeAgent())("P", "O", "K") == expect
