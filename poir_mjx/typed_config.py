"""The one validation mechanism of the project's typed, frozen config dataclasses (POIR, the sweep, the baselines).

Each config class says what its field types cannot: ``ZERO_OK`` (integers that may be 0), ``SIGNED`` (numbers that
may be negative), ``UNIT`` (numbers in [0, 1]), ``OPEN_UNIT`` (numbers in [0, 1), e.g. discounts), ``BOUNDS``
({field: (low, high)}, inclusive; an integer without one is at most ``MAX_INT``), ``EMPTY_OK`` (lists that may be
empty), and a ``cross_check(prefix)`` method for rules between fields. ``check`` applies the types (``Literal``, bool, int, float,
str, dict, ``tuple[X, ...]``, nested configs) and then those; ``from_dict`` builds a config from plain data
(JSON) and checks it. A ConfigError names the dotted field.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from typing import Literal


MAX_INT = 2**31 - 1  # any integer field's ceiling unless its class's BOUNDS says otherwise (seeds: uint32)
SEED = (0, 2**32 - 1)  # a seed's bounds: what jax.random.PRNGKey takes
NOISE = (0.0, 10.0)  # a noise level's bounds (a standard deviation in radians or action units)


class ConfigError(ValueError):
    """A configuration value is malformed; the message names the field."""


def check(cfg, prefix: str = ""):
    """Validate `cfg` (recursively) and return it; the first bad value raises a ConfigError naming its field."""
    hints = typing.get_type_hints(type(cfg))
    rules = {k: set(getattr(cfg, k, ())) for k in ("ZERO_OK", "SIGNED", "UNIT", "OPEN_UNIT", "EMPTY_OK")}
    rules["BOUNDS"] = dict(getattr(cfg, "BOUNDS", {}))
    for f in dataclasses.fields(cfg):
        v, name, t = getattr(cfg, f.name), prefix + f.name, hints[f.name]
        if dataclasses.is_dataclass(t):
            if not dataclasses.is_dataclass(v):
                raise ConfigError(f"{name}: expected a {t.__name__}, got {v!r}")
            check(v, name + ".")
        elif typing.get_origin(t) is tuple:
            if not isinstance(v, tuple) or not (v or f.name in rules["EMPTY_OK"]):
                raise ConfigError(f"{name}: must be a non-empty list, got {v!r}")
            dup = sorted({x for x in v if v.count(x) > 1}, key=str)
            if dup:
                raise ConfigError(f"{name}: lists {dup[0]!r} more than once")
            for x in v:
                _check_value(x, typing.get_args(t)[0], name, f.name, rules)
        else:
            _check_value(v, t, name, f.name, rules)
    cross = getattr(cfg, "cross_check", None)
    if cross is not None:
        cross(prefix)
    return cfg


def _check_value(v, t, name: str, field: str, rules: dict) -> None:
    if typing.get_origin(t) is Literal:
        if v not in typing.get_args(t):
            raise ConfigError(f"{name}: {v!r} is not one of {typing.get_args(t)}")
    elif t is bool:
        if not isinstance(v, bool):
            raise ConfigError(f"{name}: expected a boolean, got {v!r}")
    elif t is int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise ConfigError(f"{name}: expected an integer, got {v!r}")
        if v < 0 and field not in rules["SIGNED"] or (v == 0 and field not in rules["ZERO_OK"]):
            raise ConfigError(f"{name}: must be {'>= 0' if field in rules['ZERO_OK'] else 'positive'}, got {_short(v)}")
        lo, hi = rules["BOUNDS"].get(field, (None, MAX_INT))
        if (lo is not None and v < lo) or v > hi:
            raise ConfigError(f"{name}: must be in [{lo if lo is not None else 0}, {hi}], got {_short(v)}")
    elif t is float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ConfigError(f"{name}: expected a number, got {v!r}")
        if not math.isfinite(v):
            raise ConfigError(f"{name}: must be finite, got {v!r}")
        if field in rules["UNIT"] and not 0 <= v <= 1:
            raise ConfigError(f"{name}: a fraction must be in [0, 1], got {v}")
        if field in rules["OPEN_UNIT"] and not 0 <= v < 1:
            raise ConfigError(f"{name}: must be in [0, 1), got {v}")
        if field not in rules["SIGNED"] and v < 0:
            raise ConfigError(f"{name}: must be >= 0, got {v}")
        if field in rules["BOUNDS"] and not rules["BOUNDS"][field][0] <= v <= rules["BOUNDS"][field][1]:
            raise ConfigError(f"{name}: must be in [{rules['BOUNDS'][field][0]}, {rules['BOUNDS'][field][1]}], got {v}")
    elif t is str:
        if not isinstance(v, str):
            raise ConfigError(f"{name}: expected a string, got {v!r}")
    elif t is dict:
        if not isinstance(v, dict):
            raise ConfigError(f"{name}: expected an object, got {v!r}")


def _short(v: int) -> str:
    """An integer as an error message shows it (a 5000-digit one as its digit count)."""
    return str(v) if abs(v) < 10**30 else f"an integer of {len(str(abs(v))) if abs(v) < 10**4000 else 'over 4000'} digits"


def check_keys(d: dict, cls, source: str) -> None:
    """Refuse keys of `d` that are not fields of the dataclass `cls`, naming them and `source`."""
    unknown = set(d) - {f.name for f in dataclasses.fields(cls)}
    if unknown:
        raise ConfigError(f"{source}: unknown field(s) {sorted(unknown)} for {cls.__name__}")


def from_dict(d: dict, cls, source: str = "config", validate: bool = True):
    """Build a `cls` from plain data (nested mappings for nested configs, lists for tuples) and check it (once, at
    the top: `validate` False for the nested ones); unknown, missing or mistyped fields raise a ConfigError naming
    `source` and the field."""
    if not isinstance(d, dict):
        raise ConfigError(f"{source}: expected a mapping for {cls.__name__}, got {type(d).__name__}")
    check_keys(d, cls, source)
    hints = typing.get_type_hints(cls)
    kw = {}
    for k, v in d.items():
        t = hints[k]
        if dataclasses.is_dataclass(t):
            v = from_dict(v, t, f"{source}.{k}", validate=False)
        elif typing.get_origin(t) is tuple and isinstance(v, list):
            v = tuple(v)
        kw[k] = v
    required = [f.name for f in dataclasses.fields(cls)
                if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]  # fmt: skip
    missing = [k for k in required if k not in kw]
    if missing:
        raise ConfigError(f"{source}: field '{missing[0]}' is required")
    if not validate:
        return cls(**kw)
    try:
        return check(cls(**kw))
    except ConfigError as e:
        raise ConfigError(f"{source}: {e}") from None
