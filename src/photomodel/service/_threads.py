"""The threads searches run on: one kept for the first search in flight, and extra threads for
searches that start while it is busy, which end after a second without work.

numba's OpenMP layer gives every thread that starts a parallel kernel its own team of worker
threads, kept for the thread's life. Once the process holds more of them than there are
cores, libgomp's workers sleep between parallel regions, and every region of a search pays for
waking them (an idle second team slows each search: docs/method/service.md). So the first
search in flight runs on the primary thread (its team kept), and a search that starts while it
is busy runs on an extra thread; extra threads serve the rest of a burst and end (their teams
with them) once idle for :data:`EXTRA_IDLE_S`, so that one team is left, as in a process that
searches one pair at a time.
"""

from __future__ import annotations

import asyncio
import contextvars
import functools
import queue
import threading
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, TypeVar

__all__ = ["EXTRA_IDLE_S", "SearchThreads"]

T = TypeVar("T")

EXTRA_IDLE_S = 1.0
"""Seconds an extra search thread waits for work before it ends."""


class _ExtraThreads:
    """Threads made on demand for calls that find every thread busy; each ends after
    ``idle_s`` without a call."""

    def __init__(self, idle_s: float) -> None:
        self._idle_s = idle_s
        self._jobs: queue.SimpleQueue[tuple[Callable[[], Any], Future[Any]]] = (
            queue.SimpleQueue())
        self._lock = threading.Lock()
        self._idle = 0  # threads waiting for a job and not yet promised one

    def submit(self, call: Callable[[], T]) -> Future[T]:
        future: Future[T] = Future()
        with self._lock:
            self._jobs.put((call, future))
            if self._idle:
                self._idle -= 1
            else:
                threading.Thread(target=self._work, name="photomodel-search-extra",
                                 daemon=True).start()
        return future

    def _work(self) -> None:
        while True:
            try:
                call, future = self._jobs.get(timeout=self._idle_s)
            except queue.Empty:
                with self._lock:
                    if self._jobs.empty():
                        self._idle -= 1
                        return
                continue
            if future.set_running_or_notify_cancel():
                try:
                    future.set_result(call())
                except BaseException as exc:  # noqa: BLE001 - handed to the caller
                    future.set_exception(exc)
            with self._lock:
                self._idle += 1


class SearchThreads:
    """Runs blocking calls (searches, registrations, tracked frames) off the event loop and
    off the OPC UA face's thread (module docstring); one per service
    (:attr:`CellService.threads`), so that every face shares the one OpenMP team.

    How many run at once is bounded by the caller (the service's limiter); this class only
    chooses the thread. Safe to call from any thread.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._primary: ThreadPoolExecutor | None = None
        self._primary_busy = False
        self._extra = _ExtraThreads(EXTRA_IDLE_S)

    def submit(self, call: Callable[[], T]) -> Future[T]:
        """Start ``call()`` on the primary thread when it is free, else on an extra thread,
        in a copy of the caller's context (the request's actor, for the audit); its
        future."""
        call = functools.partial(contextvars.copy_context().run, call)
        with self._lock:
            if self._primary_busy:
                return self._extra.submit(call)
            self._primary_busy = True
            if self._primary is None:        # made again after close(): a new app's start
                self._primary = ThreadPoolExecutor(1, thread_name_prefix="photomodel-search")
            primary = self._primary

        def on_primary() -> Any:
            try:
                return call()
            finally:  # freed by the thread itself: a cancelled request still holds it
                with self._lock:
                    self._primary_busy = False

        try:
            return primary.submit(on_primary)
        except RuntimeError:                 # shut down meanwhile (the service is closing)
            with self._lock:
                self._primary_busy = False
            return self._extra.submit(call)

    def call(self, call: Callable[[], T]) -> T:
        """``call()`` in a search thread, waiting for it (for a caller that is a thread)."""
        return self.submit(call).result()

    async def run(self, call: Callable[[], T]) -> T:
        """``call()`` in a search thread; its result (or its exception)."""
        # shielded: a cancelled request leaves the call to run (and free the thread) anyway
        return await asyncio.shield(asyncio.wrap_future(self.submit(call)))

    def close(self) -> None:
        """Let the primary thread end once its call is done (a later call makes a new one)."""
        with self._lock:
            primary, self._primary = self._primary, None
        if primary is not None:
            primary.shutdown(wait=False)
