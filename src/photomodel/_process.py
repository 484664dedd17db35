"""Worker processes that end with the process that started them: :func:`die_with_parent`, the
initialiser of the pools of ``photomodel experiment`` and ``photomodel simulate``, so that a
run killed with ``kill -9`` leaves no worker (and, through them, no resource tracker) behind.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time

__all__ = ["die_with_parent"]


def die_with_parent(parent_pid: int, poll_s: float = 0.5) -> None:
    """End this process as soon as its parent ``parent_pid`` ends (a pool worker's initialiser).

    On Linux the kernel sends SIGKILL when the parent dies (``prctl(PR_SET_PDEATHSIG)``);
    everywhere, a daemon thread checks every ``poll_s`` seconds that the parent is still the
    parent (an orphan is adopted by another process) and ends this process otherwise.
    """
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)   # 1 = PR_SET_PDEATHSIG
    if os.getppid() != parent_pid:   # the parent died before the line above took effect
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(poll_s)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, name="photomodel-parent-watch", daemon=True).start()
