"""Writing files so that a crash loses nothing already written: a whole file replaced at once
(:func:`write_atomic`, or :func:`write_atomic_with` for a library that writes the file itself,
:func:`write_file_storage` for OpenCV's ``FileStorage``) and lines appended to a log or table
(:func:`append_lines`)."""

from __future__ import annotations

import errno
import fcntl
import os
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import cv2

__all__ = ["append_lines", "locked", "write_atomic", "write_atomic_with", "write_file_storage"]


def write_atomic(path: str | os.PathLike[str], data: bytes, *, mode: int = 0o644,
                 fsync: bool = True) -> None:
    """Replace ``path`` with ``data`` at once: a temporary file beside it
    (``.<name>.tmp-<pid>-<thread>``), flushed to disk, renamed over it; the temporary file is
    removed when anything fails, and ``path`` is then as it was.

    Parameters
    ----------
    path : path
    data : bytes
    mode : int
        Permission bits of a new file (``0o600`` for a private key).
    fsync : bool
        Flush the file to disk before the rename.
    """
    path = Path(path)
    tmp = _temporary(path, path.name, "")
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, mode)
        try:
            _write_all(fd, data, fsync)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_atomic_with(path: str | os.PathLike[str], write: Callable[[Path], object], *,
                      fsync: bool = True) -> None:
    """Replace ``path`` with the file that ``write`` writes to the temporary path it is given,
    for a library that writes a file itself (``cv2.FileStorage``, ``savefig``, an animation
    writer); the guarantees of :func:`write_atomic`.

    The temporary file (``.<stem>.tmp-<pid>-<thread><suffix>``, beside ``path``) keeps
    ``path``'s suffix, from which such libraries pick the format. Its permission bits are the
    library's (the umask's).

    Parameters
    ----------
    path : path
    write : callable
        Called once with the temporary path; raises when it cannot write. A call that
        returns without writing the file is an error (``FileNotFoundError``).
    fsync : bool
        Flush the file to disk before the rename.
    """
    path = Path(path)
    tmp = _temporary(path, path.stem, path.suffix)
    try:
        write(tmp)
        try:
            fd = os.open(tmp, os.O_RDONLY)
        except FileNotFoundError:
            raise FileNotFoundError(errno.ENOENT, "nothing was written", str(path)) from None
        try:
            if fsync:
                os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_file_storage(path: Path, write: Callable[[cv2.FileStorage], None]) -> None:
    """Replace ``path`` with what ``write`` writes to a ``cv2.FileStorage`` (format from the
    suffix: .yaml, .xml, .json), atomically (:func:`write_atomic_with`); its folder is
    created when missing."""
    import cv2

    def storage(tmp: Path) -> None:
        fs = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE)
        try:
            write(fs)
        finally:
            fs.release()

    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic_with(path, storage)


@contextmanager
def locked(path: str | os.PathLike[str]) -> Iterator[None]:
    """Hold an exclusive ``fcntl`` lock on ``path`` (created when missing; a lock file beside
    what it guards) for the ``with`` block, against other processes."""
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)                         # closing releases the lock


def append_lines(path: str | os.PathLike[str], lines: Sequence[bytes], *, mode: int = 0o640,
                 fsync: bool = True, header: bytes | None = None) -> None:
    """Append ``lines`` (each without its line break) to ``path`` in one ``write``.

    A last line cut short by a crash (no line break at the end of the file) is dropped
    first: it was never wholly written, and every line before it stays readable. Call it
    holding :func:`locked` when several processes append to one file.

    Parameters
    ----------
    path : path
        Created (with ``mode``) when missing.
    lines : sequence of bytes
        Each must hold no line break.
    mode : int
        Permission bits of a new file.
    fsync : bool
        Flush to disk after the write (a process that is killed loses nothing written
        either way; this guards against a power cut).
    header : bytes, optional
        A line (a table's column names) written first, in the same ``write``, when the file
        holds no whole line: new, empty, or all of it cut short.
    """
    if any(b"\n" in line or b"\r" in line for line in (*lines, header or b"")):
        raise ValueError("a line to append holds a line break")
    fd = os.open(path, os.O_RDWR | os.O_APPEND | os.O_CREAT, mode)
    try:
        size = os.fstat(fd).st_size
        if size and os.pread(fd, 1, size - 1) != b"\n":
            tail = os.pread(fd, min(size, 1 << 20), max(0, size - (1 << 20)))
            size = (size - len(tail) + tail.rfind(b"\n") + 1 if b"\n" in tail
                    else max(0, size - len(tail)))
            os.ftruncate(fd, size)
        first = [header] if header is not None and size == 0 else []
        _write_all(fd, b"".join(line + b"\n" for line in (*first, *lines)), fsync)
    finally:
        os.close(fd)


def _temporary(path: Path, stem: str, suffix: str) -> Path:
    """A temporary name beside ``path`` that no other process or thread uses."""
    return path.with_name(f".{stem}.tmp-{os.getpid()}-{threading.get_ident()}{suffix}")


def _write_all(fd: int, data: bytes, fsync: bool) -> None:
    """Write all of ``data`` to ``fd`` (one ``write`` unless the system takes less), then
    flush it to disk with ``fsync``."""
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]
    if fsync:
        os.fsync(fd)
