"""Command-line flags generated from a typed config (``POIRConfig`` and its sub-configs).

``flags_type(PlannerConfig)`` is a frozen dataclass with the same fields, nested the same way, each
leaf ``Optional`` and unset (``None``) by default, its help text the field's docstring: tyro turns it
into ``--planner.sigma``, ``--normalizer.clip``, ... . ``dotted(flags)`` gives the fields that were
set, as the dotted overrides of ``experiments/*.json`` (``{"planner.sigma": 0.1}``).
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import textwrap
import typing
from typing import Annotated, Literal, Optional

import tyro


def field_docs(cls) -> dict[str, str]:
    """The docstring under each field of a dataclass, as one paragraph."""
    docs: dict[str, str] = {}
    body = ast.parse(textwrap.dedent(inspect.getsource(cls))).body[0].body
    for a, b in zip(body, body[1:]):
        if (isinstance(a, ast.AnnAssign) and isinstance(a.target, ast.Name) and isinstance(b, ast.Expr)
                and isinstance(b.value, ast.Constant) and isinstance(b.value.value, str)):  # fmt: skip
            docs[a.target.id] = " ".join(b.value.value.split())
    return docs


def _metavar(t) -> str:
    if typing.get_origin(t) is Literal:
        return "{" + ",".join(str(x) for x in typing.get_args(t)) + "}"
    return {bool: "{True,False}", int: "INT", float: "FLOAT", str: "STR"}.get(t, "VALUE")


def flags_type(cls, hint: str, exclude: tuple[str, ...] = ()):
    """A frozen dataclass mirroring the dataclass `cls`: every leaf optional and unset, `exclude` left out
    (dotted names, e.g. "planner.reward"); `hint` is the help's note on what an unset flag means."""
    hints, docs, fields = typing.get_type_hints(cls), field_docs(cls), []
    for f in dataclasses.fields(cls):
        if f.name in exclude:
            continue
        t, doc = hints[f.name], docs.get(f.name, "")
        if dataclasses.is_dataclass(t):
            sub = [e[len(f.name) + 1 :] for e in exclude if e.startswith(f.name + ".")]
            sub_t = flags_type(t, hint, tuple(sub))
            fields.append((f.name, Annotated[sub_t, tyro.conf.arg(help=doc)], dataclasses.field(default=sub_t())))
        else:
            arg = tyro.conf.arg(help=doc, metavar=_metavar(t), help_behavior_hint=hint)
            fields.append((f.name, Annotated[Optional[t], arg], dataclasses.field(default=None)))
    out = dataclasses.make_dataclass(f"{cls.__name__}Flags", fields, frozen=True)
    out.__module__ = __name__
    return out


def dotted(flags, prefix: str = "") -> dict:
    """{dotted field name: value} of the flags that were set."""
    out = {}
    for f in dataclasses.fields(flags):
        v = getattr(flags, f.name)
        if dataclasses.is_dataclass(v):
            out.update(dotted(v, f"{prefix}{f.name}."))
        elif v is not None:
            out[prefix + f.name] = v
    return out
