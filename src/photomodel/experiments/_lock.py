"""The guard of a run directory: :func:`run_lock` lets one run at a time write it. A second
``photomodel experiment`` into the same ``--out`` is refused with one line naming the directory
and the pid of the run that holds it, instead of both appending every record. The lock is an
exclusive ``flock`` on ``DIR/.lock``; the kernel releases it when its process ends, however it
ends (``kill -9`` included), so a dead run never blocks the next one.

The workers of a run end with it through :func:`photomodel._process.die_with_parent`.
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Iterator
from pathlib import Path

from photomodel.errors import InputError

__all__ = ["LOCK_NAME", "run_lock"]

LOCK_NAME = ".lock"
"""The lock file of a run directory."""

_held: dict[str, tuple[int, int]] = {}  # run directory -> (fd, depth) held by this process
_held_guard = threading.Lock()


@contextlib.contextmanager
def run_lock(out: str | os.PathLike[str]) -> Iterator[None]:
    """Hold the exclusive lock of run directory ``out`` (which must exist) inside.

    Re-entrant within a process (the CLI holds it around a run and its report, the run
    function holds it again). Without ``fcntl`` (not POSIX) no lock is taken.

    Raises
    ------
    InputError
        Another process holds the lock: names ``out`` and, when known, that process's pid.
    """
    try:
        import fcntl
    except ImportError:
        yield
        return
    path = Path(out) / LOCK_NAME
    key = os.path.realpath(path)
    with _held_guard:
        if key in _held:
            fd, depth = _held[key]
            _held[key] = (fd, depth + 1)
            reentered = True
        else:
            reentered = False
    if not reentered:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise InputError(out, f"cannot write to the run directory ({exc.strerror})") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = _read_pid(fd)
            os.close(fd)
            who = f"process {holder}" if holder else "another process"
            raise InputError(out, f"is being written by another run ({who}); wait for it to "
                                  "end, or choose another --out") from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        with _held_guard:
            _held[key] = (fd, 1)
    try:
        yield
    finally:
        with _held_guard:
            fd, depth = _held[key]
            if depth > 1:
                _held[key] = (fd, depth - 1)
            else:
                del _held[key]
                os.close(fd)  # releases the lock (the file stays: removing it would race)


def _read_pid(fd: int) -> int | None:
    try:
        text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
        return int(text) if text.isdigit() else None
    except OSError:
        return None
