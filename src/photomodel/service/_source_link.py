"""The service's hold on its camera source: one grab at a time, a stop noticed and the source
re-opened in the background, and what ``/health`` says about it."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any

from photomodel.service._source import CameraSource, SourceError, StereoGrab

__all__ = ["GRAB_TIMEOUT_S", "RETRY_MAX_S", "RETRY_S", "SourceLink"]

log = logging.getLogger("photomodel.service")

GRAB_TIMEOUT_S = 5.0
"""How long a grab may wait for a pair, s."""

RETRY_S = 1.0
"""First wait before re-opening a stopped source, s (then doubled up to :data:`RETRY_MAX_S`):
never more often than once a second."""

RETRY_MAX_S = 5.0
"""Longest wait between two attempts to re-open a stopped source, s."""


class SourceLink:
    """A camera source as the service holds it.

    Opens the source at once (its errors reach the caller: a source that cannot be opened at
    start-up stops the start). A grab whose source has stopped (:class:`SourceError` with
    ``stopped``, or any other error of the source) closes it and marks the link ``down``;
    a thread then re-opens it with ``opener`` after :data:`RETRY_S`, doubling the wait up to
    :data:`RETRY_MAX_S`, until it opens again (``ok``). Grabs while down fail at once with
    the reason. A refused pair (skew, size) leaves the source open.

    Parameters
    ----------
    opener : callable
        Opens the source (at once, and again after a stop).
    retry_s, retry_max_s : float
        The first and the longest wait between re-opening attempts, s (at least 1 s).
    """

    def __init__(self, opener: Callable[[], CameraSource], *, retry_s: float = RETRY_S,
                 retry_max_s: float = RETRY_MAX_S) -> None:
        if not 1.0 <= retry_s <= retry_max_s:
            raise ValueError(f"retry_s: expected 1 s <= retry_s <= retry_max_s, got {retry_s:g} "
                             f"and {retry_max_s:g}")
        self._opener = opener
        self.retry_s, self.retry_max_s = retry_s, retry_max_s
        source = opener()
        self.name = source.name
        self.fps = source.fps
        self._source: CameraSource | None = source
        self._facts = source.describe()
        self._grab_lock = threading.Lock()     # one grab at a time
        self._lock = threading.Lock()          # the state below
        self._closed = threading.Event()
        self._retry: threading.Thread | None = None
        self.state = "ok"
        self.detail = "grabbing"
        self.grabbed = self.refused = self.stops = self.reopened = 0
        self.last_t_s: float | None = None
        self.last_error: str | None = None

    @property
    def current(self) -> CameraSource | None:
        """The source open now (None while down)."""
        return self._source

    @property
    def up(self) -> bool:
        """Whether the source is open (not stopped)."""
        return self._source is not None

    def grab(self, timeout_s: float = GRAB_TIMEOUT_S, *, newest: bool = True) -> StereoGrab:
        """A fresh pair (:class:`SourceError` when the source is down, stops now, or
        refuses the pair); ``newest`` as for :meth:`CameraSource.grab`."""
        with self._grab_lock:
            with self._lock:
                source = self._source
                if source is None:
                    raise SourceError(self.name, self.detail)
            try:
                grab = source.grab(timeout_s, newest=newest)
            except SourceError as exc:
                if exc.stopped:
                    self._down(source, exc.problem)
                    raise SourceError(self.name, self.detail) from None
                with self._lock:
                    self.refused += 1
                    self.last_error = str(exc)
                raise
            except Exception as exc:  # noqa: BLE001 - a driver's error: the source stopped
                log.exception("serve: camera source %s failed", self.name)
                self._down(source, f"{type(exc).__name__}: {exc}")
                raise SourceError(self.name, self.detail) from None
            with self._lock:
                self.grabbed += 1
                self.last_t_s = grab.t_s
            return grab

    def _down(self, source: CameraSource, reason: str) -> None:
        """Close a stopped source and start re-opening it in the background."""
        try:
            source.close()
        except Exception:  # noqa: BLE001 - closing a broken source may fail too
            log.debug("serve: closing %s failed", self.name, exc_info=True)
        with self._lock:
            self._source = None
            self.state = "down"
            self.stops += 1
            self.last_error = reason
            self.detail = (f"stopped: {reason}; re-opening it every {self.retry_s:g}-"
                           f"{self.retry_max_s:g} s")
            if self._closed.is_set() or (self._retry is not None and self._retry.is_alive()):
                return
            self._retry = threading.Thread(target=self._reopen, name="photomodel-source-retry",
                                           daemon=True)
            self._retry.start()
        log.warning("serve: camera source %s", self.detail)

    def _reopen(self) -> None:
        wait_s = self.retry_s
        while not self._closed.wait(wait_s):
            try:
                source = self._opener()
            except Exception as exc:  # noqa: BLE001 - still gone: try again later
                with self._lock:
                    self.detail = (f"stopped: {self.last_error}; re-opening failed "
                                   f"({exc}); next try in {min(2 * wait_s, self.retry_max_s):g}"
                                   " s")
                wait_s = min(2.0 * wait_s, self.retry_max_s)
                continue
            with self._lock:
                if self._closed.is_set():
                    source.close()
                    return
                self._source = source
                self._facts = source.describe()
                self.state, self.detail = "ok", f"grabbing again (re-opened at {_utc()})"
                self.reopened += 1
            log.warning("serve: camera source %s re-opened", self.name)
            return

    def health(self) -> dict[str, Any]:
        """``/health``'s ``source`` object: ``name``, ``state`` (``"ok"`` | ``"down"``),
        ``detail``, the source's facts (``kind``, ``fps``, ...), ``frames`` (pairs grabbed),
        ``refused``, ``stops``, ``reopened``, ``last_frame_t_s`` and ``last_error``."""
        with self._lock:
            return {**self._facts, "name": self.name, "state": self.state,
                    "detail": self.detail, "frames": self.grabbed, "refused": self.refused,
                    "stops": self.stops, "reopened": self.reopened,
                    "last_frame_t_s": self.last_t_s, "last_error": self.last_error}

    def close(self) -> None:
        """Close the source and stop re-opening it."""
        self._closed.set()
        with self._lock:
            source, self._source = self._source, None
            self.state, self.detail = "down", "closed"
        if source is not None:
            source.close()


def _utc() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
