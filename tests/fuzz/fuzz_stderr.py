"""Capture of file descriptor 2 around a fuzz run: nothing but photomodel's own messages
(which the loaders raise, not print) may reach stderr."""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from collections.abc import Iterator


@contextlib.contextmanager
def stderr_of_run() -> Iterator[list[str]]:
    """Point fd 2 at a temporary file for the body; the yielded list then holds what was
    written there."""
    written: list[str] = []
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield written
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            written.append(tmp.read().decode("utf-8", "replace"))
