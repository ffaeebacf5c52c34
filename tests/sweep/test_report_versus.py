"""The sweep report's paired comparison with EBC (poir_mjx/sweep/report.py)."""

from scipy.stats import fisher_exact

from poir_mjx.eval.stats import pooled_p_value
from poir_mjx.sweep.report import _ranks, _versus_table
from poir_mjx.sweep.config import SweepConfig


def test_versus_table_gives_differences_and_fisher_p():
    cfg = SweepConfig(name="t", methods=("EBC", "POIR-DRIL", "POIR-prior"), sigma_init=(0.02, 0.3))
    cols = [(0.02, 0.0), (0.3, 0.0)]
    table = {("EBC", 0.02, 0.0): {"k": 40, "n": 50}, ("EBC", 0.3, 0.0): {"k": 10, "n": 50},
             ("POIR-DRIL", 0.02, 0.0): {"k": 30, "n": 50}, ("POIR-DRIL", 0.3, 0.0): {"k": 25, "n": 50},
             ("POIR-prior", 0.02, 0.0): {"k": 40, "n": 50}}  # fmt: skip
    md = _versus_table(cfg, table, cols)
    p = fisher_exact([[25, 25], [10, 40]]).pvalue
    pooled = pooled_p_value([(30, 50, 40, 50), (25, 50, 10, 50)])
    assert "| method | σ_init 0.02 | σ_init 0.3 | all cells |" in md
    assert (f"| POIR-DRIL | -10 (p {fisher_exact([[30, 20], [40, 10]]).pvalue:.2g}) | +15 (p {p:.2g}) "
            f"| +5 (p {pooled:.2g}) |") in md
    assert "| POIR-prior | +0 (p 1) | - | - |" in md  # one cell: nothing to pool
    assert _versus_table(SweepConfig(name="t", methods=("POIR-DRIL", "BC")), table, cols) == ""


def test_versus_random_selection_compares_the_ranking_planners_only():
    cfg = SweepConfig(name="t", methods=("EBC", "POIR-random", "POIR-DRIL", "POIR-prior", "POIR-noprior"),
                      sigma_init=(0.3,))  # fmt: skip
    table = {(m, 0.3, 0.0): {"k": k, "n": 50} for m, k in
             (("EBC", 20), ("POIR-random", 30), ("POIR-DRIL", 25), ("POIR-prior", 20), ("POIR-noprior", 0))}
    md = _versus_table(cfg, table, [(0.3, 0.0)], "POIR-random", _ranks)
    assert "| POIR-DRIL | -5 (p" in md and "all cells" not in md and "POIR-prior" not in md and "POIR-noprior" not in md and "| EBC |" not in md


def test_an_online_method_is_compared_with_its_offline_agent():
    from poir_mjx.sweep.report import _task_table

    cfg = SweepConfig(name="t", methods=("EBC", "POIR-DRIL", "POIR-DRIL online", "POIR-MOREL online"),
                      sigma_init=(0.1, 0.4))  # fmt: skip
    data = {"source": "scripted expert"}
    table = {(m, si, 0.0): {"k": k, "n": 50, "ci": (0.0, 1.0), "diverged": 0, "data": data, "simulator": "robosuite"}
             for m, ks in (("EBC", (30, 10)), ("POIR-DRIL", (29, 11)), ("POIR-DRIL online", (36, 20)),
                           ("POIR-MOREL online", (33, 15)))
             for si, k in zip((0.1, 0.4), ks)}  # fmt: skip
    md, _ = _task_table(cfg, "lift", table)
    part = md.split("Versus POIR-DRIL on the same episodes (after online fine-tuning")[1]
    pooled = pooled_p_value([(36, 50, 29, 50), (20, 50, 11, 50)])
    assert f"| POIR-DRIL online | +7 (p {fisher_exact([[36, 14], [29, 21]]).pvalue:.2g}) | +9 (p" in part
    assert f"| +16 (p {pooled:.2g}) |" in part
    assert "POIR-MOREL online" not in part  # its offline agent (POIR-MOREL) is not in the sweep


def test_the_failed_episodes_are_broken_down_where_the_cells_record_how_they_ended():
    from poir_mjx.sweep.outcome_table import summed
    from poir_mjx.sweep.report import _task_table

    cfg = SweepConfig(name="t", methods=("EBC", "POIR-random"), sigma_init=(0.2,))
    data = {"source": "scripted expert"}
    seeds = [{"success": 10, "diverged": 0, "ran_away": 30, "stalled_at_object": 6, "stalled_elsewhere": 1,
              "moving_near_object": 3, "moved_object": 4},
             {"success": 12, "diverged": 1, "ran_away": 29, "stalled_at_object": 2, "stalled_elsewhere": 2,
              "moving_near_object": 4, "moved_object": 5}]  # fmt: skip
    both = summed([{"outcomes": s} for s in seeds])
    assert both["ran_away"] == 59 and both["moved_object"] == 9 and summed([{"outcomes": seeds[0]}, {}]) is None
    base = {"n": 100, "ci": (0.0, 1.0), "diverged": 0, "data": data, "simulator": "robosuite"}
    table = {("EBC", 0.2, 0.0): {**base, "k": 22, "outcomes": both}, ("POIR-random", 0.2, 0.0): {**base, "k": 30}}
    md, _ = _task_table(cfg, "lift", table)
    assert "How the failed episodes ended (diverged / ran away / stalled at the object" in md
    assert "| EBC | 1 / 59 / 8 / 3 / 7 (9) |" in md and "| POIR-random |" not in md.split("How the failed")[1]
    old_rule = {k: v for k, v in seeds[0].items() if k != "moved_object"} | {"touched": 40}  # the first rule's count
    assert "moved_object" not in summed([{"outcomes": old_rule}, {"outcomes": seeds[1]}])
    table[("EBC", 0.2, 0.0)]["outcomes"] = summed([{"outcomes": old_rule}])
    assert "| EBC | 0 / 30 / 6 / 1 / 3 (?) |" in _task_table(cfg, "lift", table)[0]
    table[("EBC", 0.2, 0.0)]["outcomes"] = None  # published cells made before outcomes were recorded: no table
    assert "How the failed" not in _task_table(cfg, "lift", table)[0]


def test_the_expert_data_line_names_the_demo_style_and_where_they_were_recorded():
    from poir_mjx.sweep.report import _data_source

    base = {"source": "scripted expert", "expert": "v1", "simulator": "robosuite", "num_demos": 200, "sigma_init": 0.02}
    assert _data_source(base) == "scripted expert (v1, robosuite, 200 demos)"
    assert "human-like style" in _data_source({**base, "demo_style": "human_like"})
    assert _data_source({**base, "sigma_init": 0.3}).endswith("200 demos, recorded at sigma_init 0.3)")
