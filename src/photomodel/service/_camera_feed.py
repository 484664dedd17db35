"""The service's camera feed: one grabbing loop that hands the newest stereo pair to every
camera stream (``/track?source=camera``) and to the live view (``GET /camera/latest.jpg``).

One loop per service, not one per viewer: each grab of a free-running source takes the newest
frame not given yet, so two streams grabbing on their own would share the camera's frames
between them and each see half the rate. The loop runs in a thread of its own while a stream
is subscribed (or the live view was asked for a picture within :data:`IDLE_S`), grabs from
whatever source the service holds at the time (:attr:`CellService.source`, re-opened by the
service after a stop) and publishes each pair, or the reason there is none, to every
waiting subscriber. The loop grabs the newest pair first, then oldest first
(``grab(newest=False)``: a source with buffers hands over what queued while the loop was
late) and keeps the last :data:`RECENT` pairs, so that a stream late for a moment tracks
every pair; a subscriber further behind skips to the oldest pair kept.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.errors import PhotomodelError
from photomodel.service._source import SourceError, StereoGrab

__all__ = ["IDLE_S", "LIVE_WIDTH_PX", "CameraFeed", "FeedState"]

IDLE_S = 3.0
"""How long the loop goes on grabbing after the live view's last request, s."""

RETRY_S = 0.25
"""Wait between two grabs while the source is down or refuses pairs, s (the service re-opens
a stopped source by itself; this only keeps the loop from spinning)."""

RECENT = 8
"""Pairs the feed keeps for streams that fall behind (about 0.13 s at 60 fps)."""

LIVE_WIDTH_PX = 640
"""Largest width of the live view's JPEG, pixels (larger views are scaled down)."""

TRACKED_FRESH_S = 1.0
"""How long a stream's tracked pose is drawn on the live view after it was tracked, s."""


@dataclass(frozen=True)
class FeedState:
    """What the feed has published so far.

    Attributes
    ----------
    pairs : int
        Pairs grabbed since the feed began (the number of ``grab``).
    grab : StereoGrab or None
        The newest pair.
    errors : int
        Error events so far (a new one for each stop or refusal, not for each failed retry
        with the same reason).
    error : str or None
        The newest error, None once a pair was grabbed after it.
    source : str or None
        The name of the source ``grab`` came from.
    recent : tuple of StereoGrab
        The last :data:`RECENT` pairs, oldest first (``grab`` last): pair number
        ``pairs - len(recent) + 1 + i`` is ``recent[i]``.
    """

    pairs: int
    grab: StereoGrab | None
    errors: int
    error: str | None
    source: str | None = None
    recent: tuple[StereoGrab, ...] = ()

    def since(self, pairs: int) -> tuple[list[StereoGrab], int]:
        """The pairs after pair number ``pairs`` that are still kept, oldest first, and how
        many after it are no longer kept."""
        new = max(0, self.pairs - pairs)
        kept = list(self.recent[len(self.recent) - min(new, len(self.recent)):]) if new else []
        return kept, new - len(kept)


class CameraFeed:
    """The grabbing loop of a :class:`~photomodel.service.CellService` (``cell.feed``).

    Parameters
    ----------
    cell : CellService
        Whose ``source`` is grabbed (read at every grab: a source attached later is used).
    idle_s : float
        How long the loop goes on after the last :meth:`touch` without subscribers, s.
    """

    def __init__(self, cell: Any, *, idle_s: float = IDLE_S) -> None:
        self._cell = cell
        self.idle_s = idle_s
        self._cond = threading.Condition()
        self._state = FeedState(0, None, 0, None)
        self._users = 0
        self._keep_until = 0.0
        self._thread: threading.Thread | None = None
        self._closed = threading.Event()
        self._tracked: dict[str, tuple[float, StereoGrab, NDArray[np.float64] | None]] = {}

    @property
    def state(self) -> FeedState:
        """What was published last."""
        with self._cond:
            return self._state

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called (the service is closing)."""
        return self._closed.is_set()

    @property
    def running(self) -> bool:
        """Whether the loop is grabbing now."""
        with self._cond:
            return self._thread is not None

    @contextmanager
    def subscribed(self) -> Iterator[CameraFeed]:
        """Keep the loop grabbing while the block runs (a camera stream)."""
        with self._cond:
            self._users += 1
            self._start()
        try:
            yield self
        finally:
            with self._cond:
                self._users -= 1
                self._keep_until = max(self._keep_until, time.monotonic() + 0.1)

    def touch(self) -> None:
        """Keep the loop grabbing for :attr:`idle_s` more seconds (the live view)."""
        with self._cond:
            self._keep_until = time.monotonic() + self.idle_s
            self._start()

    def wait(self, pairs: int, errors: int, timeout_s: float) -> FeedState:
        """The state once it has more than ``pairs`` pairs or ``errors`` errors, or after
        ``timeout_s`` s, whichever comes first."""
        with self._cond:
            self._cond.wait_for(lambda: self._state.pairs > pairs or self._state.errors > errors
                                or self._closed.is_set(), timeout_s)
            return self._state

    def close(self) -> None:
        """Stop the loop for good (the service closes)."""
        self._closed.set()
        with self._cond:
            self._cond.notify_all()

    def _start(self) -> None:
        """Start the loop if it is not running (called holding the lock)."""
        if self._thread is None and not self._closed.is_set():
            self._thread = threading.Thread(target=self._run, name="photomodel-camera-feed",
                                            daemon=True)
            self._thread.start()

    def _run(self) -> None:
        fresh = True        # the first pair of a run (and after an outage): the newest
        while True:
            with self._cond:
                if self._closed.is_set() or (self._users == 0
                                             and time.monotonic() > self._keep_until):
                    self._thread = None
                    return
            link = self._cell.source
            try:
                if link is None:
                    raise SourceError("source", "this service has no camera source (start it "
                                                "with --source sim, replay:DIR or opencv:R,L)")
                grab = link.grab(newest=fresh)
            except PhotomodelError as exc:
                fresh = True
                self._publish_error(str(exc))
                self._closed.wait(RETRY_S)
                continue
            fresh = False
            with self._cond:
                s = self._state
                self._state = FeedState(s.pairs + 1, grab, s.errors, None, link.name,
                                        (*s.recent, grab)[-RECENT:])
                self._cond.notify_all()

    def _publish_error(self, message: str) -> None:
        with self._cond:
            s = self._state
            if s.error == message:          # the same outage: said once
                return
            self._state = FeedState(s.pairs, s.grab, s.errors + 1, message, s.source,
                                    s.recent)
            self._cond.notify_all()

    # --- the live view ------------------------------------------------------------------------

    def tracked(self, model: str, grab: StereoGrab, T_cam1_model: NDArray[np.float64] | None
                ) -> None:
        """Note the pose a camera stream tracked for ``model`` on ``grab`` (None: lost), for
        the live view."""
        with self._cond:
            self._tracked[model] = (time.monotonic(), grab, T_cam1_model)

    def live_jpeg(self, model: str | None = None, overlay: bool = True,
                  timeout_s: float = 5.0) -> bytes:
        """Camera 1's newest view as a JPEG at most :data:`LIVE_WIDTH_PX` wide; with
        ``model`` and ``overlay``, the view a camera stream last tracked ``model`` on (when
        within :data:`TRACKED_FRESH_S`) with the model's outline at the tracked pose.

        Raises
        ------
        SourceError
            No pair within ``timeout_s`` (the source is down, or there is none): the reason.
        """
        was_running = self.running
        self.touch()
        state = self.state
        if state.grab is None or not was_running:     # none yet, or an old one: the next
            deadline = time.monotonic() + timeout_s
            first = state
            while time.monotonic() < deadline:
                state = self.wait(first.pairs, state.errors, deadline - time.monotonic())
                if state.pairs > first.pairs or (state.errors > first.errors
                                                 and state.grab is None):
                    break
            if state.pairs == first.pairs and state.error is not None:
                raise SourceError("source", state.error)
        if state.grab is None:
            raise SourceError("source", state.error or f"no pair within {timeout_s:g} s")
        grab, T = state.grab, None
        if model is not None and overlay:
            with self._cond:
                seen = self._tracked.get(model)
            if seen is not None and time.monotonic() - seen[0] <= TRACKED_FRESH_S:
                _, grab, T = seen
        outline = None
        if T is not None:
            locator = self._cell.locator(model)
            uv, _ = self._cell.rig.project_poses(T, locator.model.outline_mm)
            outline = uv
        return _jpeg(grab.right_bgr, outline)


def _jpeg(image: NDArray[np.uint8], outline: NDArray[np.float64] | None) -> bytes:
    """``image`` with the polygon ``outline`` (N, 2) (u, v) px drawn, scaled down to at most
    :data:`LIVE_WIDTH_PX` wide, as a JPEG."""
    scale = min(1.0, LIVE_WIDTH_PX / image.shape[1])
    out = image if scale == 1.0 else cv2.resize(image, None, fx=scale, fy=scale,
                                                interpolation=cv2.INTER_AREA)
    if outline is not None and len(outline) and np.isfinite(outline).all():
        out = out.copy() if out is image else out
        points = np.rint(outline * scale).astype(np.int32).reshape(-1, 1, 2)
        cv2.polylines(out, [points], True, (0, 255, 255), 2, cv2.LINE_AA)
    ok, buf = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, 80])
    if not ok:  # pragma: no cover - OpenCV encodes any uint8 BGR image
        raise RuntimeError("cannot encode a JPEG")
    return buf.tobytes()
