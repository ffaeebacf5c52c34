"""One process at a time per run folder: an exclusive ``fcntl.flock`` on ``<folder>/.lock``, held while the command
writes there. The kernel releases it when the holder exits, however it exits (kill -9 included), so a lock left
by a dead process never blocks the next run; the file holds the holder's pid for the one-line refusal."""

from __future__ import annotations

import contextlib
import fcntl
import os
from pathlib import Path

from poir_mjx.typed_config import ConfigError

LOCK_NAME = ".lock"


@contextlib.contextmanager
def locked(folder, what: str = "run folder"):
    """Hold `folder`'s lock (made with the folder if need be) for the block; a ConfigError naming the folder and the
    holder's pid if another process holds it. A folder this call made is removed again if the block fails having
    written nothing there."""
    folder = Path(folder)
    made = [p for p in (folder, *folder.parents) if not p.exists()]  # what this call makes (removed if left empty)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / LOCK_NAME
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
    except OSError as e:
        raise ConfigError(f"{path}: cannot open the {what}'s lock ({e.strerror})") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
            raise ConfigError(f"{folder}: another process (pid {holder}) is writing this {what}; wait for it to "
                              "finish, or use another name") from None  # fmt: skip
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield
        made = []  # the command ran to its end: its folder stays
    finally:
        if made and [p.name for p in folder.iterdir()] == [LOCK_NAME]:  # refused before writing: leave no trace
            path.unlink()
            for p in made:
                with contextlib.suppress(OSError):
                    p.rmdir()
        os.close(fd)  # releases the lock
