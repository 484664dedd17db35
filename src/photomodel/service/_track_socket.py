"""WebSocket ``/track?model=NAME``: stereo frames in, one pose per frame out.

A frame is one binary message: a 4-byte big-endian length ``n``, ``n`` bytes of a JSON
header, then camera 1's image and camera 2's image (:func:`encode_frame`). The header says
``right_bytes`` and ``left_bytes`` (the images' lengths), ``encoding`` (``"png"``, the
default: any image file OpenCV reads; or ``"raw"``: ``shape`` ``[H, W, 3]`` uint8 BGR pixels)
and optionally ``t_s`` (the frame's time, s). A text message ``{"reset": true}`` starts the
tracking over.

Each processed frame is answered by one text message: the ``track --json`` object
(:meth:`~photomodel.track.TrackResult.to_json_dict`) plus ``pose_stamped`` (null when lost),
``received`` (frames received so far) and ``dropped`` (frames dropped so far). A bad frame,
and a text message other than ``{"reset": ...}``, is answered by ``{"error": ...,
"received": ..., "dropped": ...}`` and the stream goes on. The newest frame wins:
while a frame is being tracked, only the latest one that arrives is kept, the ones it
replaces are counted as dropped (and in ``/metrics``), so a slow client never makes the
server queue frames.

Answers on demand (``/track?model=NAME&credit=N``): the server then sends at most as many
answers as the client has asked for, ``N`` at the start and ``k`` more with each text message
``{"credit": k}``; while none is asked for, frames are still tracked (the newest wins, the
others are dropped) and only the latest answer is kept, sent when the next one is asked for
(the answers then also count the ``superseded`` ones: tracked, replaced before asked for).
An error about a text message is answered at once and costs no credit. A client that reads
slowly grants one answer after each it has read and so always gets the answer to the newest
frame it can, never a backlog of old ones, while the tracker sees every frame it can keep up
with.

From the service's camera (``/track?model=NAME&source=camera``): the server tracks the pairs
of its camera source instead of frames sent by the client; one answer per tracked pair, the
object above plus ``frame_index`` (the pair's number at its source), ``frame_t_s`` (its time,
unix s; also the tracker's ``t_s`` and ``pose_stamped``'s stamp) and ``source`` (its name).
``received`` counts the pairs the stream was handed, ``dropped`` those it skipped: a camera
stream tracks its pairs in order, holding up to :data:`QUEUED_PAIRS` while it tracks an
earlier one (a late moment loses nothing; the oldest are dropped beyond); ``credit`` and
``{"reset": true}`` work as above. The client sends only text messages: a binary one is
answered with an error and ignored. The pairs come from the service's one grabbing loop
(:class:`~photomodel.service._camera_feed.CameraFeed`), shared by every camera stream, so two
viewers do not halve each other's frame rate. A source that stops or refuses a pair is
answered once with ``{"error": ..., "source": NAME}`` (free of credit) and the stream waits
for the service to re-open it; a service without a camera source refuses the stream
(``{"error"}``, close 1008).
"""

from __future__ import annotations

import contextlib
import json
import math
import struct
import time
from collections import deque
from collections.abc import Awaitable, Callable
from functools import partial
from typing import Any

import anyio
import numpy as np
from numpy.typing import NDArray
from prometheus_client import CollectorRegistry, Counter, Histogram
from starlette.websockets import WebSocket, WebSocketDisconnect

from photomodel.errors import InputError, PhotomodelError
from photomodel.service._source import StereoGrab

__all__ = ["decode_frame", "encode_frame", "track_endpoint"]

_LENGTH = struct.Struct(">I")
MAX_HEADER_BYTES = 4096
"""Largest JSON header of a frame message."""
POLICY_VIOLATION = 1008
"""WebSocket close code of a refused stream (unknown model, bad query)."""
MAX_CREDIT = 1_000_000
"""Most answers a client may ask for ahead (``credit``)."""
QUEUED_PAIRS = 8
"""Camera pairs a stream holds while it tracks an earlier one (oldest dropped beyond)."""


def encode_frame(right: bytes, left: bytes, *, t_s: float | None = None,
                 shape: tuple[int, int, int] | None = None) -> bytes:
    """One frame message: PNG (or other image file) bytes of both cameras, or raw BGR pixels
    with ``shape`` (H, W, 3)."""
    header: dict[str, Any] = {"right_bytes": len(right), "left_bytes": len(left),
                              "encoding": "png" if shape is None else "raw"}
    if shape is not None:
        header["shape"] = list(shape)
    if t_s is not None:
        header["t_s"] = float(t_s)
    head = json.dumps(header).encode()
    return _LENGTH.pack(len(head)) + head + right + left


def decode_frame(message: bytes) -> tuple[NDArray[np.uint8], NDArray[np.uint8], float | None]:
    """Camera 1's and camera 2's images (H, W, 3) uint8 BGR and the time of a frame message.

    Raises
    ------
    InputError
        Naming what is wrong with the message.
    """
    from photomodel.image import decode_color_images

    if len(message) < _LENGTH.size:
        raise InputError("frame", "shorter than its 4-byte header length")
    (n,) = _LENGTH.unpack_from(message)
    if n > MAX_HEADER_BYTES or _LENGTH.size + n > len(message):
        raise InputError("frame", f"header length {n} is not within the message")
    try:
        header = json.loads(message[_LENGTH.size:_LENGTH.size + n])
        if not isinstance(header, dict):
            raise ValueError("not an object")
        sizes = int(header["right_bytes"]), int(header["left_bytes"])
        encoding = str(header.get("encoding", "png"))
        t_s = header.get("t_s")
        t_s = None if t_s is None else float(t_s)
    except (ValueError, KeyError, TypeError) as exc:
        raise InputError("frame header", f"expected JSON with right_bytes and left_bytes "
                                         f"({exc})") from None
    if t_s is not None and not math.isfinite(t_s):
        raise InputError("frame header", f"t_s: expected a finite time, got {t_s}")
    start = _LENGTH.size + n
    if min(sizes) < 1 or start + sum(sizes) != len(message):
        raise InputError("frame", f"right_bytes + left_bytes ({sum(sizes)}) do not match the "
                                  f"{len(message) - start} bytes after the header")
    right_b = message[start:start + sizes[0]]
    left_b = message[start + sizes[0]:]
    if encoding == "png":
        right, left = decode_color_images([(right_b, "right image"), (left_b, "left image")])
        return right, left, t_s
    if encoding != "raw":
        raise InputError("frame header", f"encoding: expected 'png' or 'raw', got {encoding!r}")
    try:
        shape = tuple(int(v) for v in header["shape"])
    except (KeyError, TypeError, ValueError):
        raise InputError("frame header", "raw frames need shape [H, W, 3]") from None
    if len(shape) != 3 or shape[2] != 3 or min(shape) < 1:
        raise InputError("frame header", f"shape: expected [H, W, 3], got {list(shape)}")
    if sizes[0] != int(np.prod(shape)) or sizes[1] != int(np.prod(shape)):
        raise InputError("frame", f"raw images of shape {list(shape)} take "
                                  f"{int(np.prod(shape))} bytes each, got {list(sizes)}")
    return (np.frombuffer(right_b, np.uint8).reshape(shape).copy(),
            np.frombuffer(left_b, np.uint8).reshape(shape).copy(), t_s)


class _TrackMetrics:
    """The stream's Prometheus metrics, in the service's registry."""

    def __init__(self, registry: CollectorRegistry) -> None:
        self.frames = Counter("photomodel_track_frames", "Frames received on /track, by outcome",
                              ["outcome"], registry=registry)
        self.seconds = Histogram("photomodel_track_seconds", "Wall time of a tracked frame",
                                 buckets=(0.002, 0.004, 0.008, 0.016, 0.033, 0.066, 0.1, 0.25,
                                          0.5, 1.0), registry=registry)


class _Stream:
    """One ``/track`` connection: its tracker, what waits to be tracked, its counts, and the
    three tasks that run it (:meth:`receive` the client's messages, :meth:`pump` the camera's
    pairs, :meth:`answer` track and send)."""

    def __init__(self, ws: WebSocket, cell: Any, name: str, tracker: Any, metrics: _TrackMetrics,
                 finite: Callable[[Any], Any], credit: int | None, camera: bool) -> None:
        self.ws, self.cell, self.name, self.tracker = ws, cell, name, tracker
        self.metrics, self.finite = metrics, finite
        self.credit, self.camera = credit, camera
        self.frame: bytes | None = None                   # a client's newest frame
        self.queue: deque[tuple[StereoGrab, str | None]] = deque()  # the camera's pairs
        self.received = self.dropped = self.superseded = 0
        self.open, self.reset = True, False
        self.text_error: str | None = None
        self.source_error: str | None = None
        self.arrived = anyio.Event()

    def _drop(self, n: int = 1) -> None:
        self.dropped += n
        self.metrics.frames.labels("dropped").inc(n)

    def _poke(self) -> None:
        self.arrived.set()

    def track(self, message: bytes | tuple[StereoGrab, str | None]) -> dict[str, Any]:
        """Track one client frame or camera pair (in a search thread); its answer."""
        from photomodel.service._ros import pose_stamped

        if isinstance(message, bytes):
            right, left, t_s = decode_frame(message)
            result = self.tracker(right, left, t_s=t_s)
            stamp_s = time.time()
        else:
            grab, source = message
            result = self.tracker(grab.right_bgr, grab.left_bgr, t_s=grab.t_s)
            stamp_s = grab.t_s
            self.cell.feed.tracked(self.name, grab, None if result.mode == "lost"
                                   else result.T_cam1_model)
        answer = result.to_json_dict()
        answer["pose_stamped"] = (None if result.mode == "lost"
                                  else pose_stamped(result.T_cam1_model, stamp_s))
        if not isinstance(message, bytes):
            answer.update(frame_index=grab.index, frame_t_s=grab.t_s, source=source)
        return answer

    async def receive(self) -> None:
        """The client's messages: frames (the newest wins), resets, credit."""
        try:
            while True:
                message = await self.ws.receive()
                if message["type"] == "websocket.disconnect":
                    break
                if message.get("bytes") is not None and self.camera:
                    self.text_error = ("binary message: a camera stream (source=camera) "
                                       "takes no frames; ignored")
                elif message.get("bytes") is not None:
                    self.received += 1
                    if self.frame is not None:
                        self._drop()
                    self.frame = message["bytes"]
                elif message.get("text") is not None:
                    try:
                        reset, more = _control(message["text"])
                    except InputError as exc:
                        self.text_error = str(exc)    # the latest one is answered
                    else:
                        self.reset = self.reset or reset  # not cancelled later
                        if more and self.credit is not None:
                            self.credit = min(self.credit + more, MAX_CREDIT)
                self._poke()
        finally:
            self.open = False
            self._poke()

    async def pump(self) -> None:
        """Queue the feed's pairs in order (at most :data:`QUEUED_PAIRS`; the oldest are
        dropped beyond) and note its errors."""
        feed = self.cell.feed
        seen = feed.state
        if seen.error is not None:
            self.source_error = seen.error
            self._poke()
        while self.open and not feed.closed:
            now = await anyio.to_thread.run_sync(feed.wait, seen.pairs, seen.errors, 0.5)
            if now.errors > seen.errors and now.error is not None:
                self.source_error = now.error
            kept, lost = now.since(seen.pairs)
            self.received += len(kept) + lost
            if lost:
                self._drop(lost)
            for grab in kept:
                if len(self.queue) == QUEUED_PAIRS:
                    self.queue.popleft()
                    self._drop()
                self.queue.append((grab, now.source))
            seen = now
            self._poke()

    async def send(self, out: dict[str, Any], spend: bool = True) -> bool:
        """Send one answer with the counts (spending one credit when ``spend``); False when
        the client has gone."""
        out.update(received=self.received, dropped=self.dropped)
        if self.credit is not None:
            out["superseded"] = self.superseded
            if spend:
                self.credit -= 1
        try:
            await self.ws.send_text(json.dumps(self.finite(out), allow_nan=False))
        except (WebSocketDisconnect, RuntimeError):
            return False
        return True

    def _next(self) -> bytes | tuple[StereoGrab, str | None] | None:
        if self.camera:
            if not self.queue:
                return None
            pair = self.queue.popleft()
            if self.queue:
                self._poke()                  # more wait: come round again
            return pair
        frame, self.frame = self.frame, None
        return frame

    async def answer(self) -> None:
        """Track what waits and send the answers (errors first, free of credit)."""
        pending: dict[str, Any] | None = None
        while True:
            await self.arrived.wait()
            self.arrived = anyio.Event()
            if not self.open:
                return
            if self.text_error is not None:
                error, self.text_error = self.text_error, None
                if not await self.send({"error": error}, spend=False):
                    return
            if self.source_error is not None:          # likewise: the source stopped
                error, self.source_error = self.source_error, None
                if not await self.send({"error": error, "source": self.cell.feed.state.source},
                                       spend=False):
                    return
            if self.reset:
                self.reset = False
                self.tracker.reset()
            frame = self._next()
            if frame is not None:
                if pending is not None:
                    self.superseded += 1              # tracked, never asked for
                t0 = time.perf_counter()
                try:
                    pending = await self.cell.threads.run(partial(self.track, frame))
                    self.metrics.frames.labels("tracked").inc()
                    self.metrics.seconds.observe(time.perf_counter() - t0)
                except PhotomodelError as exc:
                    self.metrics.frames.labels("bad").inc()
                    pending = {"error": str(exc)}
            # with credit, the answer waits until it is asked for (a newer one replaces it)
            if pending is not None and (self.credit is None or self.credit > 0):
                out, pending = pending, None
                if not await self.send(out):
                    return

    async def run(self) -> None:
        with contextlib.ExitStack() as held:
            if self.camera:
                held.enter_context(self.cell.feed.subscribed())
            async with anyio.create_task_group() as tasks:
                tasks.start_soon(self.receive)
                if self.camera:
                    tasks.start_soon(self.pump)
                await self.answer()
                tasks.cancel_scope.cancel()


def track_endpoint(cell: Any, registry: CollectorRegistry,
                   finite: Callable[[Any], Any]) -> Callable[[WebSocket], Awaitable[None]]:
    """The ``/track`` WebSocket endpoint of the cell service ``cell`` (a
    :class:`~photomodel.service.CellService`), its metrics in ``registry``; ``finite`` maps
    NaN to None in an answer."""
    from photomodel.track import Tracker

    metrics = _TrackMetrics(registry)

    async def endpoint(ws: WebSocket) -> None:
        await ws.accept()
        name = ws.query_params.get("model")
        try:
            if not name:
                raise InputError("model", "expected /track?model=NAME")
            locator = await anyio.to_thread.run_sync(cell.locator, name)
            tracker = await anyio.to_thread.run_sync(Tracker, locator.model, cell.rig)
            credit = _initial_credit(ws.query_params.get("credit"))
            camera = _camera(ws.query_params.get("source"), cell)
        except PhotomodelError as exc:
            await ws.send_json({"error": str(exc)})
            await ws.close(code=POLICY_VIOLATION)
            return
        await _Stream(ws, cell, name, tracker, metrics, finite, credit, camera).run()

    return endpoint


def _control(text: str) -> tuple[bool, int]:
    """What a text message asks: to start over (``{"reset": true}``) and how many more
    answers (``{"credit": k}``, k from 1 to :data:`MAX_CREDIT`).

    Raises
    ------
    InputError
        When the message is not a JSON object with the key ``reset`` or ``credit``, or its
        credit is not such a count.
    """
    try:
        doc = json.loads(text)
    except ValueError:
        doc = None
    if not isinstance(doc, dict) or not ({"reset", "credit"} & set(doc)):
        shown = text if len(text) <= 60 else text[:57] + "..."
        raise InputError("text message", f'expected {{"reset": true}} or {{"credit": k}}, '
                         f"got {shown!r}")
    credit = doc.get("credit", 0)
    if "credit" in doc and not (isinstance(credit, int) and not isinstance(credit, bool)
                                and 1 <= credit <= MAX_CREDIT):
        raise InputError("credit", f"expected a count from 1 to {MAX_CREDIT}, got {credit!r}")
    return bool(doc.get("reset", False)), int(credit)


def _camera(value: str | None, cell: Any) -> bool:
    """Whether the ``source`` query parameter asks for the service's camera (``camera``);
    InputError for another value, or for ``camera`` on a service without a source."""
    if value is None:
        return False
    if value != "camera":
        raise InputError("source", f"expected source=camera (or none: frames sent by the "
                                   f"client), got {value!r}")
    if cell.source is None:
        raise InputError("source", "this service has no camera source (start it with "
                                   "--source sim, replay:DIR or opencv:R,L)")
    return True


def _initial_credit(value: str | None) -> int | None:
    """The ``credit`` query parameter as a count (None: answers are not asked for)."""
    if value is None:
        return None
    try:
        credit = int(value)
    except ValueError:
        credit = -1
    if not 0 <= credit <= MAX_CREDIT:
        raise InputError("credit", f"expected a count from 0 to {MAX_CREDIT}, got {value!r}")
    return credit
