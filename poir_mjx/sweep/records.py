"""The schema of a sweep's cell records, checked on every read (``read_cell``: the sweep's loop, its cell runners, the
tables, the learning curves and ``compare`` all read through it). A record that breaks it is one line naming the
file and the field; nothing built on a hand-edited or damaged record reaches a table.

A record is a JSON object (no key given twice) with
- ``config_hash``: the hash of what shaped it (another hash: a stale record, recomputed, never an error);
- ``episodes``: an integer in [1, MAX_COUNT], the config's episodes per cell;
- ``successes`` and ``diverged`` (0 when absent): integers in [0, episodes];
- ``task``, ``method``, ``seed``, ``sigma_init``, ``sigma_action``, where present: the cell's own (a record copied
  to another cell's file is refused).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from poir_mjx.typed_config import ConfigError

MAX_COUNT = 10**9  # episodes per cell: far above any sweep, far below what overflows a table's arithmetic
ADVICE = "delete the file to recompute the cell"


def _no_duplicates(path: Path):
    def hook(pairs):
        keys = [k for k, _ in pairs]
        dup = next((k for k in keys if keys.count(k) > 1), None)
        if dup is not None:
            raise ConfigError(f"{path}: field '{dup}' is given more than once; {ADVICE}")
        return dict(pairs)

    return hook


def load_record(path: Path) -> dict | None:
    """The JSON object at `path` (no key twice), None if there is none; ``read_cell`` checks the rest."""
    path = Path(path)
    try:
        rec = json.loads(path.read_bytes().decode("utf-8"), object_pairs_hook=_no_duplicates(path))
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError, ValueError) as e:
        if isinstance(e, ConfigError):
            raise
        why = type(e).__name__ if isinstance(e, RecursionError) else e
        raise ConfigError(f"{path}: not a readable cell record ({why}); {ADVICE}") from None
    if not isinstance(rec, dict):
        raise ConfigError(f"{path}: not a cell record (expected a JSON object); {ADVICE}")
    return rec


def _check_counts(path: Path, rec: dict) -> None:
    n = rec.get("episodes")
    counts = (("episodes", n, 1, MAX_COUNT), ("successes", rec.get("successes"), 0, n),
              ("diverged", rec.get("diverged", 0), 0, n))  # fmt: skip
    for name, v, lo, hi in counts:
        if isinstance(v, bool) or not isinstance(v, int) or v < 0:
            raise ConfigError(f"{path}: field '{name}' must be a count (an integer >= 0), got {_short(v)}; {ADVICE}")
        if not lo <= v <= hi:
            bound = f"field 'episodes' ({n})" if name != "episodes" else f"{hi}"
            what = f"exceeds {bound}" if v > hi else f"must be at least {lo}"
            raise ConfigError(f"{path}: field '{name}' ({_short(v)}) {what}; {ADVICE}")


def read_cell(path: Path, chash: str, expect: dict | None = None) -> dict | None:
    """The cell's record if it exists and was made with config hash `chash`; None if absent or from another config.
    expect: fields the record must carry with these values (the config's episodes, the cell's task, method, seed and
    noise levels); a record of this config that differs is refused, naming the field."""
    rec = load_record(path)
    if rec is None or rec.get("config_hash") != chash:
        return None
    _check_counts(path, rec)
    for name, want in (expect or {}).items():
        have = rec.get(name, want if name != "episodes" else None)
        same = have == want if not isinstance(want, float) else (isinstance(have, (int, float)) and
                                                                 math.isclose(have, want, rel_tol=1e-12))  # fmt: skip
        if not same or isinstance(have, bool) != isinstance(want, bool):
            raise ConfigError(f"{path}: field '{name}' is {_short(have)}, the config's cell has {want!r}; {ADVICE}")
    return rec


def _short(v) -> str:
    text = repr(v)
    return text if len(text) <= 40 else text[:37] + "..."
