"""The threads searches run on: one kept for the first search in flight, a short-lived one
for each search that starts while it is busy.

numba's OpenMP layer gives every thread that starts a parallel kernel its own team of worker
threads, kept for the thread's life. Once the process holds more of them than there are
cores, libgomp's workers stop spinning between parallel regions and sleep at once, and every
region of a search pays for waking them: with one search running, a second team left idle
made each search about 3 ms slower (16.5 -> 19.9 ms on 2 cores). So the first search in
flight runs on the primary thread (its team kept), and a search that starts while it is busy
runs on a thread of its own that ends with it, taking its team along: after a burst of
concurrent requests one team is left, as in a process that searches one pair at a time.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any, TypeVar

__all__ = ["SearchThreads"]

T = TypeVar("T")


class SearchThreads:
    """Runs blocking calls (searches, registrations) off the event loop (module docstring).

    How many run at once is bounded by the caller (the service's limiter); this class only
    chooses the thread.
    """

    def __init__(self) -> None:
        self._primary = ThreadPoolExecutor(1, thread_name_prefix="photomodel-search")
        self._primary_busy = False

    async def run(self, call: Callable[[], T]) -> T:
        """``call()`` in a search thread; its result (or its exception)."""
        loop = asyncio.get_running_loop()
        if self._primary_busy:
            own = ThreadPoolExecutor(1, thread_name_prefix="photomodel-search-extra")
            try:
                return await loop.run_in_executor(own, call)
            finally:
                own.shutdown(wait=False)  # the thread ends after the call, its team with it
        self._primary_busy = True

        def on_primary() -> Any:
            try:
                return call()
            finally:  # freed by the thread itself: a cancelled request still holds it
                loop.call_soon_threadsafe(self._free)

        # shielded: a cancelled request leaves the call to run (and free the thread) anyway
        return await asyncio.shield(loop.run_in_executor(self._primary, on_primary))

    def _free(self) -> None:
        self._primary_busy = False

    def close(self) -> None:
        """Let the primary thread end once its call is done."""
        self._primary.shutdown(wait=False)
