"""A run's "how the failed episodes ended" table (eval/outcomes.py), from the cells that record it."""

from __future__ import annotations

from poir_mjx.eval.outcomes import OUTCOMES
from poir_mjx.sweep.plan import noise_label

FAILURES = tuple(o for o in OUTCOMES if o != "success")
SHORT = {"diverged": "diverged", "ran_away": "ran away", "stalled_at_object": "stalled at the object",
         "stalled_elsewhere": "stalled elsewhere", "moving_near_object": "moving near the object"}


def summed(recs: list[dict]) -> dict | None:
    """The cells' outcome counts summed over their seeds; None unless every record has them."""
    if not recs or any(not isinstance(r.get("outcomes"), dict) for r in recs):
        return None
    out = {k: sum(int(r["outcomes"].get(k, 0)) for r in recs) for k in OUTCOMES}
    if all("moved_object" in r["outcomes"] for r in recs):  # records of the first rule carry "touched": not shown
        out["moved_object"] = sum(int(r["outcomes"]["moved_object"]) for r in recs)
    return out


def outcome_table(cfg, table: dict, cols: list) -> str:
    """Markdown: per method and cell, the failed episodes by how they ended; empty if no cell records outcomes."""
    if not any(c.get("outcomes") for c in table.values()):
        return ""
    from poir_mjx.eval import outcomes as oc

    legend = " / ".join(SHORT[k] for k in FAILURES)
    md = ["", f"How the failed episodes ended ({legend}; in brackets, failures that pushed the object more than "
          f"{oc.TOUCH_M * 100:g} cm or raised it; ? where a cell was recorded before that count): at the end the hand was more than {oc.RAN_AWAY_M * 100:g} cm from the object "
          f"(ran away), or had moved less than {oc.REST_M * 100:g} cm over the last {oc.REST_STEPS} steps within "
          f"{oc.AT_OBJECT_M * 100:g} cm of it or farther (stalled), or neither (`poir_mjx/eval/outcomes.py`).", "",
          "| method | " + " | ".join(noise_label(si, sa, cfg) for si, sa in cols) + " |",
          "|---|" + "---|" * len(cols)]  # fmt: skip
    for m in cfg.methods:
        cells = []
        for si, sa in cols:
            o = (table.get((m, si, sa)) or {}).get("outcomes")
            if o is None:
                cells.append("-")
                continue
            moved = f" ({o['moved_object']})" if "moved_object" in o else " (?)"
            cells.append(" / ".join(str(o[k]) for k in FAILURES) + moved)
        if any(c != "-" for c in cells):
            md.append(f"| {m} | " + " | ".join(cells) + " |")
    return "\n".join(md) + "\n"
