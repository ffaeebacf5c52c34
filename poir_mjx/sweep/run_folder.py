"""A sweep's results folder: a plain name under the results root, one config per folder, writable.

``results/<name>/config.json`` records the sweep config the folder's cells were made with; a run
with a different config under the same name is refused (unless the caller asks to replace it), so
a config that reuses a published run's name cannot silently mix its cells into that run.
"""

from __future__ import annotations

import json
import os
import re
import tempfile
from pathlib import Path

from poir_mjx.atomic import atomic_write_text
from poir_mjx.core.config import ConfigError

NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")
# Sweep config fields that are gone, and what a config file says instead (a recorded config is migrated).
RETIRED = {"epochs": '"overrides": {"train.epochs": N}'}


def upgrade_recorded(config: dict) -> dict:
    """A run folder's recorded sweep config in today's fields: ``epochs`` (gone) becomes the override
    ``train.epochs`` (0, the preset's, is dropped; an override already there wins), and a config without
    ``ranking`` (recorded before the field, when every run ranked as printed) gets ``"ranking": "paper"``. The POIR
    config, and so every cell's config hash, is the same either way; a folder made before the change is not "a
    different config"."""
    if "ranking" not in config:
        config = {**config, "ranking": "paper"}
    if "epochs" not in config:
        return config
    config = dict(config)
    epochs = config.pop("epochs")
    if epochs and isinstance(config.get("overrides", {}), dict):
        config["overrides"] = {"train.epochs": epochs, **config.get("overrides", {})}
    elif epochs:
        config["epochs"] = epochs  # malformed overrides: left for the config check to name
    return config


def run_name_problem(name) -> str | None:
    """What is wrong with a run name (None: nothing). A run name is a plain folder name: letters, digits, '.',
    '_', '-', not starting with '.'."""
    if not isinstance(name, str) or not NAME.fullmatch(name) or len(name) > 100:
        return f"must be a plain folder name (letters, digits, '.', '_', '-'), got {name!r}"
    return None


def check_run_name(name: str, source: str) -> str:
    problem = run_name_problem(name)
    if problem:
        raise ConfigError(f"{source}: field 'name' {problem}")
    return name


def check_writable(folder: Path, what: str) -> None:
    """Make `folder` (and its parents) and write a probe file there; else one line naming it."""
    try:
        Path(folder).mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(dir=folder, prefix=".write-check.")
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise ConfigError(f"{folder}: {what} is not writable ({e.strerror})") from None


def prepare(out: Path, config: dict, replace_config: bool = False, defaults: dict | None = None) -> None:
    """``check_config``, then record `config` in `out` (config.json)."""
    atomic_write_text(out / "config.json", check_config(out, config, replace_config, defaults))


def check_config(out: Path, config: dict, replace_config: bool = False, defaults: dict | None = None) -> str:
    """Create `out`, check it is writable and that `config` may run there (the recorded one or a replacement the
    caller asked for); returns config.json's text, which the caller writes once the run has done work (a run refused
    later leaves no config behind).

    defaults: the config's default values; a field the recorded config lacks (it predates the field) counts as its
    default, so adding a field to the config does not orphan existing run folders."""
    check_writable(out, "results folder")
    recorded = out / "config.json"
    text = json.dumps(config, indent=2, sort_keys=True) + "\n"
    new = json.loads(text)  # as it reads back (tuples become lists)
    has_cells = (out / "cells").is_dir() and any(p.is_file() for p in (out / "cells").rglob("*.json"))
    holds_results = has_cells or any(out.glob("*.md"))
    if not recorded.is_file() and holds_results and not replace_config:
        raise ConfigError(f"{out}: holds results but no config.json (made by hand, or by an older poir-mjx); "
                          "use another run name")  # fmt: skip
    if recorded.is_file() and holds_results:  # a config alone (a refused run's) guards nothing: it is replaced
        try:
            old = json.loads(recorded.read_text())
        except (OSError, json.JSONDecodeError) as e:
            raise ConfigError(f"{recorded}: unreadable ({e}); delete it if the folder's cells are to be recomputed") from None
        if not isinstance(old, dict):
            raise ConfigError(f"{recorded}: not a sweep config (expected a JSON object, got {type(old).__name__})")
        if old == new:
            return text
        old = upgrade_recorded(old)
        if defaults is not None:
            old = {**json.loads(json.dumps(defaults)), **old}
        if not replace_config and old != new:
            diff = sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))
            raise ConfigError(f"{recorded}: this run folder was made with a different config (fields {diff}); "
                              "use another name, or --replace-config to recompute the changed cells here")  # fmt: skip
    return text


def published_digests(run: Path) -> dict[str, str]:
    """{task: the expert data's digest} its cell records name, of a run folder (empty when it has none)."""
    return {task: rec["data"]["sha256"] for task, rec in _first_records(run).items()
            if isinstance(rec.get("data"), dict) and isinstance(rec["data"].get("sha256"), str)}  # fmt: skip


def published_versions(run: Path) -> dict[str, str]:
    """{package: version} the first cell record of a run folder names (its "stack"; empty when it has none)."""
    for rec in _first_records(run).values():
        if isinstance(rec.get("stack"), dict):
            return {k: v for k, v in rec["stack"].items() if isinstance(v, str)}
    return {}


def _first_records(run: Path) -> dict[str, dict]:
    """{task: its first readable cell record} of a run folder."""
    out = {}
    for f in sorted(Path(run).glob("cells/*/*/*.json")):
        try:
            rec = json.loads(f.read_text())
        except (OSError, ValueError):
            continue
        if isinstance(rec, dict):
            out.setdefault(f.parent.parent.name, rec)
    return out


def demo_note(name: str, out: Path, digests: dict[str, str], published_root: Path = Path("results"),
              versions: dict[str, str | None] | None = None) -> str | None:  # fmt: skip
    """One line when a run of a published run's name (elsewhere, e.g. `make sweep` in results/local/) trains on other
    expert data, or runs other software versions (`versions`; default: this process's), than the published run did:
    its tables then differ within sampling error, not by a regression."""
    from poir_mjx.outputs import published_run
    from poir_mjx.versions import stack

    published = Path(published_root) / name
    if published.resolve() == Path(out).resolve() or published_run(published) is None:
        return None
    theirs = published_digests(published)
    differ = [f"{t} {digests[t]} here, {theirs[t]} there" for t in sorted(digests) if t in theirs and
              theirs[t] != digests[t]]  # fmt: skip
    mine, recorded = stack() if versions is None else versions, published_versions(published)
    other = [f"{p} {mine.get(p)} here, {v} there" for p, v in sorted(recorded.items()) if mine.get(p, v) != v]
    if not differ and not other:
        return None
    parts = ([f"the expert data ({'; '.join(differ)})"] if differ else []) + (
        [f"the software ({'; '.join(other)})"] if other else [])  # fmt: skip
    return (f"note: {' and '.join(parts)} differ from the published run {published}'s: robosuite records other "
            "demos on another machine, and other versions compute in another order, so the tables will differ "
            "within sampling error, not by a regression (docs/reliability.md)")
