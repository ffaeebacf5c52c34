"""Every path a command writes, checked in one place before any work (the command line calls ``check_options`` on
each command's options; the sweep calls ``check_run_folder`` on its run folder, whose name its config gives).

The rules, whatever the command:
- an output file is a plain file name: never a directory, a symbolic link, or a special file (a device such as
  /dev/full, a fifo, a socket), and its folder is a folder that can be written;
- an output folder is a folder (or can be made), never a file or a special file;
- a name that becomes a file name (``bench env --name``) is a plain name: no '/', no '..';
- nothing is written inside a *published run*: a folder whose ``config.json`` git tracks (results/<name>/ of a run
  that was committed). Published runs are read-only for every command, ``sweep --replace-config`` included
  (``report --tables``, which rewrites their tables from their own committed cell records, is the one exception);
- inside a run folder, no symbolic link leads out of it and nothing the sweep writes is a directory or a special
  file.
Each refusal is a ConfigError naming the flag or file: one line, exit status 2.
"""

from __future__ import annotations

import os
import re
import stat
import subprocess
from pathlib import Path

from poir_mjx.typed_config import ConfigError

NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


def name_problem(name) -> str | None:
    """What is wrong with a name that becomes a file or folder name (None: nothing): letters, digits, '.', '_',
    '-', not starting with '.', at most 100 characters."""
    if not isinstance(name, str) or not NAME.fullmatch(name) or len(name) > 100:
        return f"must be a plain file name (letters, digits, '.', '_', '-'), got {name!r}"
    return None


def check_name(name, flag: str) -> None:
    problem = name_problem(name)
    if problem:
        raise ConfigError(f"{flag}: {problem}")


def _tracked(path: Path) -> bool:
    """Whether git tracks `path` (committed or staged); False outside a work tree or without git."""
    try:
        done = subprocess.run(["git", "ls-files", "--error-unmatch", "--", path.name], cwd=path.parent,
                              capture_output=True, timeout=60)  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        return False
    return done.returncode == 0


def published_run(path) -> Path | None:
    """The published run folder `path` lies in (or is), symbolic links followed: the nearest folder above it (or
    itself) whose config.json git tracks; None when there is none."""
    p = Path(os.path.abspath(path))
    try:
        p = p.resolve()
    except (OSError, RuntimeError):  # a symlink loop: left for the write to fail on
        pass
    for d in (p, *p.parents):
        cfg = d / "config.json"
        try:
            if cfg.is_file() and _tracked(cfg):
                return d
        except OSError:
            continue
    return None


def _refuse_published(path, flag: str) -> None:
    run = published_run(path)
    if run is not None:
        raise ConfigError(f"{flag}: {path} is in the published run {run} (its config.json is tracked by git), which "
                          "no command writes; give another path or run name")  # fmt: skip


def _existing_ancestor(path: Path) -> Path:
    parent = Path(os.path.abspath(path))
    while not os.path.lexists(parent):
        parent = parent.parent
    return parent


def _kind(st: os.stat_result) -> str:
    mode = st.st_mode
    if stat.S_ISLNK(mode):
        return "a symbolic link"
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISREG(mode):
        return "a file"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISFIFO(mode):
        return "a fifo"
    return "a socket" if stat.S_ISSOCK(mode) else "a special file"


def check_file(path, flag: str) -> None:
    """`path` can be written as a new or replaced regular file (see the module's rules), before any work."""
    path = Path(path)
    _check_not_special(path, flag)
    _refuse_published(path, flag)
    parent = _existing_ancestor(path.parent)
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise ConfigError(f"{flag}: {path} cannot be written ({parent} is not a writable folder)")


def _check_not_special(path: Path, flag: str) -> None:
    """`path` is absent or a regular file (not a directory, a symbolic link, a device, a fifo or a socket)."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        st = None
    except NotADirectoryError:
        blocker = _existing_ancestor(path.parent)
        raise ConfigError(f"{flag}: {path} cannot be written ({blocker} is {_kind(os.lstat(blocker))}, expected a "
                          "folder)") from None  # fmt: skip
    except OSError as e:
        raise ConfigError(f"{flag}: {path} cannot be written ({e.strerror})") from None
    if st is not None and not stat.S_ISREG(st.st_mode):
        what = _kind(st)
        hint = "expected a file name" if what == "a directory" else "give a regular file's name"
        raise ConfigError(f"{flag}: {path} is {what}, {hint}")


def check_folder(folder, flag: str) -> None:
    """`folder` is (or can be made as) a writable folder outside every published run, before any work."""
    folder = Path(folder)
    if os.path.lexists(folder):
        try:
            st = os.stat(folder)  # a link to a folder is a folder (e.g. data/ on another disk)
        except OSError as e:
            raise ConfigError(f"{flag}: {folder} cannot be used ({e.strerror})") from None
        if not stat.S_ISDIR(st.st_mode):
            raise ConfigError(f"{flag}: {folder} is {_kind(st)}, expected a folder")
    _refuse_published(folder, flag)
    parent = _existing_ancestor(folder)
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise ConfigError(f"{flag}: {folder} cannot be written ({parent} is not a writable folder)")


def check_run_folder(out, files=(), source: str = "run folder") -> None:
    """A run folder a command is about to write: not a published run, no symbolic link inside leading out of it,
    nothing inside that is a special file, and each of `files` (the paths it will write) a writable file name."""
    out = Path(out)
    run = published_run(out)
    if run is not None:
        raise ConfigError(f"{out}: the published run {run} (its config.json is tracked by git) is read-only, "
                          f"--replace-config included; give the {source} another name or --results folder")  # fmt: skip
    if os.path.lexists(out):
        check_folder(out, source)
        root = out.resolve()
        for here, dirs, names in os.walk(out):
            for name in dirs + names:
                p = Path(here) / name
                st = os.lstat(p)
                if stat.S_ISLNK(st.st_mode):
                    target = p.resolve()
                    if target != root and root not in target.parents:
                        raise ConfigError(f"{p}: a symbolic link out of the run folder (to {target}); remove it")
                elif not (stat.S_ISDIR(st.st_mode) or stat.S_ISREG(st.st_mode)):
                    raise ConfigError(f"{p}: {_kind(st)} in the run folder; remove it")
    for f in files:  # inside `out`, so not published either (no link leads out)
        _check_not_special(Path(f), source)


def check_options(opts) -> None:
    """Every output of a command's options (their ``outputs()``: (path, "file" | "folder" | "name", flag)), checked
    before the command runs."""
    for value, kind, flag in opts.outputs():
        {"file": check_file, "folder": check_folder, "name": check_name}[kind](value, flag)


def file_pair(folder, stem: str, flag: str) -> list:
    """<folder>/<stem>.json and .md as outputs (a stem that is not a plain name is refused first, by its flag)."""
    return [] if name_problem(stem) else [(Path(folder) / f"{stem}{ext}", "file", flag) for ext in (".json", ".md")]
