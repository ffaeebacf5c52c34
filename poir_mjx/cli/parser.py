"""tyro glue: the registry's commands as one parser, and tyro's parse errors as one line.

tyro 1.0.16 is pinned: the one-line errors use its parse-error hook (``tyro._errors.on_parse_error``,
documented but private); an event this module does not know falls back to tyro's own message (exit 2).
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib
from typing import Annotated, Any, Callable, Union

import tyro


def _load(ref):
    """An object, or the one a "module:name" string names."""
    if not isinstance(ref, str):
        return ref
    module, _, name = ref.partition(":")
    return getattr(importlib.import_module(module), name)


@dataclasses.dataclass(frozen=True)
class Command:
    name: str
    """The words that select it: "sweep", "demos generate"."""
    options: Any
    """Frozen dataclass of its options (or "module:Class"); its docstring is the subcommand's help."""
    run: Callable | str
    """Function taking the options (or "module:function", imported when the subcommand runs); its int
    return value is the exit status (anything else: 0)."""
    check: Callable | str | None = None
    """Optional function (or "module:function") called first, before the command line imports the simulator:
    a missing system library (e.g. OpenGL for `video`) is then one line (MissingDependencyError), exit 2."""

    def options_type(self):
        return _load(self.options)

    def function(self) -> Callable:
        return _load(self.run)

    def check_function(self) -> Callable | None:
        return None if self.check is None else _load(self.check)


def _union(members: list):
    return members[0] if len(members) == 1 else Union[tuple(members)]


def cli_type(commands, groups: dict[str, tuple[str, str | None]]):
    """The tyro type: one subcommand per command, grouped by first word ("demos generate" under "demos")."""
    top, nested = [], {}
    for c in commands:
        head, _, rest = c.name.partition(" ")
        if rest:
            nested.setdefault(head, []).append((rest, c.options_type()))
        else:
            top.append(Annotated[c.options_type(), tyro.conf.subcommand(head)])
    for head, members in nested.items():
        description, default = groups.get(head, (None, None))
        kw = {"default": dict(members)[default]()} if default else {}
        inner = _union([Annotated[t, tyro.conf.subcommand(name)] for name, t in members])
        top.append(Annotated[inner, tyro.conf.subcommand(head, description=description, **kw)])
    return _union(top)


class _ParseError(Exception):
    pass


def _flag(argument) -> str:
    try:
        return argument.display_name()
    except Exception:
        return "a flag"


def _one_line(event) -> str | None:
    """One line for a tyro parse-error event (None: let tyro print its own)."""
    from tyro import _errors as e

    sub = event.prog.partition(" ")[2]
    see = f" (see {event.prog} --help)"
    if isinstance(event, e.UnrecognizedArgs):
        return f"{sub + ': ' if sub else ''}unrecognised arguments: {' '.join(event.tokens)}{see}"
    if isinstance(event, e.InvalidChoice):
        choices = ", ".join(c for c in event.choices if c != "None")
        return f"{_flag(event.argument)}: {event.value!r} is not one of {choices}"
    if isinstance(event, e.BadValue):
        what = f"takes no value, got {event.offending_value!r}" if event.offending_value else "expects more values"
        return f"{_flag(event.argument)}: {what}"
    if isinstance(event, e.InstantiationFailure):
        msg = " ".join(event.message.split("\n")[0].split())
        return f"{_flag(event.argument)}: {msg}" if event.argument is not None else msg
    if isinstance(event, e.MissingArgs):
        where = getattr(event.missing_arguments[0].source_parser, "prog_suffix", "") if event.missing_arguments else ""
        prog = f"{event.prog} {where}".strip()
        return f"{prog}: missing {', '.join(_flag(a.arg) for a in event.missing_arguments)} (see {prog} --help)"
    if isinstance(event, e.MissingSubcommand):
        names = ", ".join(event.subcommand_spec.parser_from_name)
        return f"{event.prog}: expected a subcommand, one of {names}"
    return None


def parse(commands, groups, argv: list[str], prog: str):
    """(command, its options) from the command line; a parse error is returned as one line (a str)."""
    by_type = {c.options_type(): c for c in commands}
    if len(by_type) != len(commands):
        raise AssertionError("two commands share an options class")

    def hook(event):
        line = _one_line(event)
        if line is not None:
            raise _ParseError(line)

    on_error = getattr(getattr(tyro, "_errors", None), "on_parse_error", None)  # another tyro: its own messages
    try:
        with on_error(hook) if on_error else contextlib.nullcontext():
            opts = tyro.cli(cli_type(commands, groups), args=argv, prog=prog)
    except _ParseError as err:
        return str(err)
    empty = _empty_list(opts)
    return f"{empty}: give at least one value" if empty else (by_type[type(opts)], opts)


def _empty_list(opts) -> str | None:
    """The first flag of several values that got none where its default has some (or that has no default)."""
    for f in dataclasses.fields(opts):
        if getattr(opts, f.name) == () and f.default != ():
            return "--" + f.name.replace("_", "-") if f.default is not dataclasses.MISSING else f.name.upper()
    return None
