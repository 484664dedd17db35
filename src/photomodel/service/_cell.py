"""``CellService``: the state of one resident service (calibration, the library's
:class:`~photomodel.Identifier` with its bounded cache of prepared models, recent results),
independent of HTTP: the app calls its methods from worker threads."""

from __future__ import annotations

import dataclasses
import logging
import threading
import time
import warnings
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any
from urllib.parse import quote

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.camera import PinholeCamera, StereoRig, load_camera, load_distance_mm, load_stereo
from photomodel.errors import InputError
from photomodel.identify import CacheStats, Identifier, IdentifyConfig
from photomodel.image import decode_color_image, decode_color_images
from photomodel.library import LibraryEntry, ModelLibrary, check_model_name
from photomodel.locate import Locator, draw_overlay, draw_table_overlay, load_threshold
from photomodel.model import DEFAULT_STATION_DISTANCE_MM, PhotoModel, build_model
from photomodel.service._audit import AuditLog, file_sha256
from photomodel.service._auth import TokenBook, TokenFile, check_token
from photomodel.service._camera_feed import CameraFeed
from photomodel.service._results import Latencies, ResultRing
from photomodel.service._ros import pose_stamped
from photomodel.service._source import DEFAULT_MAX_SKEW_MS, CameraSource, StereoGrab
from photomodel.service._source_link import SourceLink
from photomodel.service._threads import SearchThreads

__all__ = ["EAGER_PREPARED", "CellService", "Conflict", "NotFound", "ServiceConfig",
           "Unavailable", "exposure_warning", "read_token"]

log = logging.getLogger("photomodel.service")

MiB = 1 << 20

EAGER_PREPARED = 8
"""Models the warm-up prepares (the library's first, by name, at most ``prepared_models``):
a library of a few models answers its first requests without preparing anything, and a
catalogue's warm-up stays a few seconds."""

PREVIEW_BYTES_KEPT = 32 * MiB
"""Preview PNGs kept in memory (least recently shown dropped beyond)."""


class NotFound(InputError):
    """An unknown model or result (HTTP 404)."""


class Conflict(InputError):
    """A registration under a name the library already holds (HTTP 409)."""


class Unavailable(InputError):
    """The service is still warming up, or its warm-up failed (HTTP 503)."""


@dataclass(frozen=True)
class ServiceConfig:
    """What ``photomodel serve`` is started with.

    Attributes
    ----------
    stereo : Path
        The hand rig's stereo calibration.
    models : Path
        The model library directory (created when missing).
    camera : Path or None
        The model station's calibration; registering garments needs it.
    searches : int
        Searches (locate, identify, registration) run at once; more wait their turn.
    results_kept : int
        Results kept in memory for ``/results`` and their overlays (oldest dropped).
    max_upload_bytes : int
        Largest request body accepted (HTTP 413 beyond).
    token : str or None
        When set, every request needs ``Authorization: Bearer <token>`` (one ``admin``).
    token_file : Path or None
        A token file of several credentials with roles
        (:func:`~photomodel.service._auth.read_tokens`), read again when it changes; it
        takes the place of ``token``.
    audit_log : Path or None
        The audit trail (default ``audit/audit.jsonl`` in the model library).
    host : str
        The address the service listens on (a non-local one without ``tls`` is warned
        about in ``/health``).
    tls : bool
        Whether the service is served over TLS.
    threshold : Path or None
        Threshold file (default: the library's ``threshold.json``, else the user's).
    source : str or None
        The camera source's spec (``sim``, ``replay:DIR``, ``opencv:R,L``;
        :func:`~photomodel.service._source.open_source`), opened at start; None: no camera,
        the trigger endpoints answer 409.
    max_skew_ms : float
        Largest difference between a pair's two timestamps, ms.
    record_dir : Path or None
        Where ``POST /record`` writes (default: ``recordings`` beside the model library).
    prepared_models : int
        Most models kept prepared for the rig (1 to 100000; the least recently used is
        dropped beyond); a model not held is loaded and prepared by the request that needs
        it. Each holds tens of MB, growing with the image area (memory and the default:
        docs/method/service.md, "Prepared models and memory").
    """

    stereo: Path
    models: Path
    camera: Path | None = None
    searches: int = 2
    results_kept: int = 20
    max_upload_bytes: int = 32 * MiB
    token: str | None = None
    threshold: Path | None = None
    prepared_models: int = 32
    source: str | None = None
    max_skew_ms: float = DEFAULT_MAX_SKEW_MS
    record_dir: Path | None = None
    token_file: Path | None = None
    audit_log: Path | None = None
    host: str = "127.0.0.1"
    tls: bool = False

    def __post_init__(self) -> None:
        if not 1 <= self.searches <= 64:
            raise ValueError(f"searches: expected 1 to 64 at once, got {self.searches}")
        if not 1 <= self.results_kept <= 1000:
            raise ValueError(f"results_kept: expected 1 to 1000, got {self.results_kept}")
        if not MiB <= self.max_upload_bytes <= 1024 * MiB:
            raise ValueError("max_upload_bytes: expected 1 MiB to 1 GiB, got "
                             f"{self.max_upload_bytes}")
        if not 1 <= self.prepared_models <= 100_000:
            raise ValueError("prepared_models: expected 1 to 100000 models kept prepared, got "
                             f"{self.prepared_models}")
        if not 0.0 <= self.max_skew_ms <= 10_000.0:
            raise ValueError(f"max_skew_ms: expected 0 to 10000 ms, got {self.max_skew_ms:g}")


def _png(image: NDArray[np.uint8]) -> bytes:
    ok, buf = cv2.imencode(".png", image)
    if not ok:  # pragma: no cover - OpenCV encodes any uint8 BGR image
        raise RuntimeError("cannot encode a PNG")
    return buf.tobytes()


def _pair_png(right: NDArray[np.uint8], left: NDArray[np.uint8], caption: str,
              model: PhotoModel | None, A_cam1_model: NDArray[np.float64] | None,
              rig: StereoRig) -> bytes:
    """The overlay of a result: the model drawn at its pose, or the bare pair with a caption."""
    A = A_cam1_model if A_cam1_model is not None else np.full((4, 4), np.nan)
    return _png(draw_overlay(model, rig, right, left, A, caption))


def _table_png(right: NDArray[np.uint8], left: NDArray[np.uint8], caption: str,
               drawn: list[tuple[PhotoModel, NDArray[np.float64], str]], rig: StereoRig
               ) -> bytes:
    """The overlay of an ``all`` result: every garment with its pick rank, name and score."""
    return _png(draw_table_overlay(rig, right, left, drawn, caption))


_PreviewKey = tuple[str, str, int, int]


def _preview_key(entry: LibraryEntry) -> _PreviewKey:
    """A model's preview stands for one version of its file: a replaced model's old preview
    is never shown again, and ages out."""
    return entry.name, entry.file, entry.file_bytes, entry.file_mtime_ns


class _Previews:
    """Preview PNGs by :func:`_preview_key`, at most ``max_bytes`` of them (least recently
    shown dropped first); safe to use from several threads."""

    def __init__(self, max_bytes: int) -> None:
        self.max_bytes = max_bytes
        self._items: OrderedDict[_PreviewKey, bytes] = OrderedDict()
        self._bytes = 0
        self._lock = threading.Lock()

    def get(self, key: _PreviewKey) -> bytes | None:
        with self._lock:
            png = self._items.get(key)
            if png is not None:
                self._items.move_to_end(key)
            return png

    def put(self, key: _PreviewKey, png: bytes) -> None:
        with self._lock:
            self._bytes -= len(self._items.pop(key, b""))
            self._items[key] = png
            self._bytes += len(png)
            while self._bytes > self.max_bytes and len(self._items) > 1:
                self._bytes -= len(self._items.popitem(last=False)[1])


class CellService:
    """One cell's resident state.

    Made from a :class:`ServiceConfig` (reads the calibrations; a bad file is an InputError
    at start), then :meth:`warm` (compile and load the kernels, open the library's index)
    before :attr:`status` turns ``"ok"``. The library is held by one
    :class:`~photomodel.Identifier`: every model's descriptor from the index (no model file
    is read to start), and at most ``prepared_models`` models prepared for the rig, each the
    first time a request needs it (least recently used dropped beyond), so that memory and
    warm-up do not grow with the catalogue. Its methods may run in several threads at once;
    registrations and removals are serialised.
    """

    def __init__(self, config: ServiceConfig) -> None:
        from photomodel.service._record import Recorder

        self.config = config
        self.rig: StereoRig = load_stereo(config.stereo)
        self.camera: PinholeCamera | None = None
        self.distance_mm = DEFAULT_STATION_DISTANCE_MM
        if config.camera is not None:
            self.camera = load_camera(config.camera)
            self.distance_mm = load_distance_mm(config.camera) or DEFAULT_STATION_DISTANCE_MM
        self.library = ModelLibrary(config.models, create=True)
        self.min_score = load_threshold(config.threshold, library=self.library.root).min_score
        self.results = ResultRing(config.results_kept)
        self.latencies = Latencies(100)
        self.status = "warming"
        self.detail = "starting"
        self.started_s = time.time()
        self.warm_seconds: float | None = None
        self.searches = config.searches
        self._identifier: Identifier | None = None   # set once by warm(), then reloaded
        self._previews = _Previews(PREVIEW_BYTES_KEPT)
        self._summaries: tuple[object, list[dict[str, Any]]] = (None, [])
        self._writing = threading.Lock()     # registrations and removals, one at a time
        self._changes = 0                    # counts the starts and ends of writes
        self.threads = SearchThreads()       # every face's searches: one OpenMP team
        self.source: SourceLink | None = None
        self.feed = CameraFeed(self)         # the camera streams' and live view's grab loop
        self.recorder = Recorder(config.record_dir or Path(config.models).parent / "recordings",
                                 config.stereo)
        self.tokens = _tokens(config)
        self.audit = AuditLog(config.audit_log or self.library.root / "audit" / "audit.jsonl")
        if config.source is not None:
            self.attach_source(config.source)

    # --- warming ---------------------------------------------------------------------------

    def warm(self, progress: Callable[[str], None] | None = None) -> None:
        """Compile (when not cached) and load every kernel, open the library from its index
        (an index of an older photomodel is upgraded with the models' descriptors first)
        and prepare the first :data:`EAGER_PREPARED` models (by name; at most
        ``prepared_models``); the others are prepared on first use. :attr:`status` is
        ``"ok"`` after, ``"failed"`` (with :attr:`detail`) when anything went wrong."""
        say = progress or log.info
        t0 = time.perf_counter()
        try:
            from photomodel._warmup import all_cached, load_kernels, warmup

            self.detail = "loading kernels"
            if not all_cached():     # compiled in spawned processes, then loaded here
                self.detail = "compiling kernels"
                warmup(say)
                self.detail = "loading kernels"
            load_kernels()
            self._check_threading(say)
            self.detail = "opening the library's index"
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                identifier = Identifier(self.library, self.rig,
                                        config=IdentifyConfig(min_score=self.min_score),
                                        prepared_models=self.config.prepared_models)
            for w in caught:
                say(f"serve: {w.message}")
            eager = identifier.names[:min(EAGER_PREPARED, self.config.prepared_models)]
            for i, name in enumerate(eager, 1):
                self.detail = f"preparing {name} ({i}/{len(eager)})"
                try:
                    identifier.locator(name)
                except InputError as exc:   # one bad file must not sink the service
                    say(f"serve: {exc}")
            self._identifier = identifier
            self.warm_seconds = time.perf_counter() - t0
            self.status, self.detail = "ok", "ready"
            say(f"serve: ready in {self.warm_seconds:.1f} s: {len(identifier)} models "
                f"({len(identifier.prepared)} prepared, at most "
                f"{self.config.prepared_models}), {self.searches} searches at once")
        except Exception as exc:  # noqa: BLE001 - reported on /health, the service stays up
            self.status, self.detail = "failed", f"warm-up failed: {exc}"
            log.exception("serve: warm-up failed")

    def _check_threading(self, say: Callable[[str], None]) -> None:
        """numba's ``workqueue`` layer cannot run parallel kernels from two threads at once:
        one search at a time then."""
        import numba

        layer = numba.threading_layer()
        if layer == "workqueue" and self.searches > 1:
            say("serve: numba's threading layer is 'workqueue' (no OpenMP or TBB): one search "
                "at a time")
            self.searches = 1

    def ready(self) -> None:
        """Raise :class:`Unavailable` unless warmed up."""
        if self.status != "ok":
            raise Unavailable("service", f"{self.status}: {self.detail}")

    @property
    def identifier(self) -> Identifier:
        """The library's Identifier (:class:`Unavailable` until warmed up)."""
        self.ready()
        identifier = self._identifier
        assert identifier is not None
        return identifier

    def prepared_stats(self) -> CacheStats | None:
        """The prepared models' counts (None until warmed up)."""
        identifier = self._identifier
        return None if identifier is None else identifier.stats()

    def _wait_for_writers(self, since: int) -> bool:
        """Whether the library changed (or is changing) since ``self._changes`` was
        ``since``; if so, returns once that change is done."""
        if self._changes == since and not self._writing.locked():
            return False
        with self._writing:
            return True

    # --- the library -------------------------------------------------------------------------

    def models(self) -> list[dict[str, Any]]:
        """Summaries of the library's models, by name (none until warmed up). Made once per
        state of the library: the same list until the next registration or removal (do not
        change it)."""
        identifier = self._identifier
        if identifier is None:
            return []
        entries = identifier.entries          # replaced, never changed, by a reload
        made_for, summaries = self._summaries
        if made_for is not entries:
            summaries = [_summary(entries[n]) for n in sorted(entries)]
            self._summaries = (entries, summaries)
        return summaries

    def model_count(self) -> int:
        """How many models the library holds (0 until warmed up)."""
        identifier = self._identifier
        return 0 if identifier is None else len(identifier.entries)

    def register(self, name: str, photo: bytes, background: bytes,
                 distance_mm: float | None = None, *, replace: bool = False) -> dict[str, Any]:
        """Build a photo-model from its two photos (the model station's ``--camera``), add it
        to the library and prepare it; returns its summary."""
        identifier = self.identifier
        if self.camera is None:
            raise InputError("photo", "registering a garment needs the service started with "
                                      "--camera (the model station's calibration)")
        check_model_name(name, "name")
        if distance_mm is not None and not (np.isfinite(distance_mm) and
                                            0 < distance_mm <= 1e5):
            raise InputError("distance_mm", f"expected a distance in (0, 100000] mm, got "
                                            f"{distance_mm:g}")
        if name in identifier.entries and not replace:
            raise _taken(name)
        photo_bgr = decode_color_image(photo, "photo")
        background_bgr = decode_color_image(background, "background")
        self.camera.check_image(photo_bgr, "photo")
        self.camera.check_image(background_bgr, "background")
        if photo_bgr.shape != background_bgr.shape:
            raise InputError("background", f"image is {background_bgr.shape[1]}x"
                                           f"{background_bgr.shape[0]} px but the photo is "
                                           f"{photo_bgr.shape[1]}x{photo_bgr.shape[0]} px")
        model = build_model(photo_bgr, background_bgr, self.camera,
                            distance_mm or self.distance_mm, name=name)
        return _summary(self.adopt(model, replace=replace))

    def adopt(self, model: PhotoModel, *, replace: bool = False, action: str | None = None
              ) -> LibraryEntry:
        """Add a built model to the library and prepare it (Conflict when its name is taken
        and ``replace`` is False); its library entry. The audit trail records it as
        ``action`` (default ``register``, or ``replace`` when the name was taken), with the
        model file's SHA-256 and the request's actor."""
        identifier = self.identifier
        name = model.name
        if name in identifier.entries and not replace:
            raise _taken(name)
        locator = identifier.prepared.make(model)
        with self._writing:
            if name in identifier.entries and not replace:
                raise _taken(name)
            action = action or ("replace" if name in identifier.entries else "register")
            self._changes += 1
            try:
                entry = self.library.add_model(model, replace=replace)
                identifier.reload()
                identifier.prepared.put(locator)
            finally:
                self._changes += 1
            self.audit.write(action, model=name,
                             sha256=file_sha256(self.library.root / entry.file))
        log.info("serve: registered %s (%.0f x %.0f mm)", name, *entry.size_mm)
        return entry

    def remove(self, name: str) -> dict[str, Any]:
        """Delete model ``name`` from the library and from memory; returns its summary."""
        identifier = self.identifier
        with self._writing:
            if name not in identifier.entries:
                raise NotFound("model", f"no model named {name!r}")
            self._changes += 1
            sha256 = file_sha256(self.library.root / identifier.entries[name].file)
            try:
                try:
                    entry = self.library.remove(name)
                except InputError:
                    identifier.reload()          # removed by another process meanwhile?
                    if name not in identifier.entries:
                        raise NotFound("model", f"no model named {name!r}") from None
                    raise
                identifier.reload()
            finally:
                self._changes += 1
            self.audit.write("delete", model=name, sha256=sha256)
        return _summary(entry)

    def preview_png(self, name: str) -> bytes:
        """The model's photo crop with its silhouette outlined (PNG); the model file is read
        when the model is not prepared."""
        identifier = self._identifier
        entry = None if identifier is None else identifier.entries.get(name)
        if identifier is None or entry is None:
            raise NotFound("model", f"no model named {name!r}")
        png = self._previews.get(_preview_key(entry))
        if png is None:
            held = identifier.prepared.peek(name)
            model = held.model if held is not None else self.library.load_entry(entry)
            image = model.photo_bgr.copy()
            contours, _ = cv2.findContours(model.mask.astype(np.uint8), cv2.RETR_EXTERNAL,
                                           cv2.CHAIN_APPROX_NONE)
            cv2.drawContours(image, contours, -1, (0, 255, 255), 1, cv2.LINE_AA)
            png = _png(image)
            self._previews.put(_preview_key(entry), png)
        return png

    # --- searches ----------------------------------------------------------------------------

    def decode_pair(self, right: bytes, left: bytes
                    ) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
        """The two uploaded views decoded (PNG, BMP or JPEG) as BGR (H, W, 3) uint8 and
        checked against the calibration (InputError naming ``right`` or ``left``)."""
        right_bgr, left_bgr = decode_color_images([(right, "right"), (left, "left")])
        self.check_pair(right_bgr, left_bgr)
        return right_bgr, left_bgr

    def check_pair(self, right_bgr: NDArray[np.uint8], left_bgr: NDArray[np.uint8]) -> None:
        """InputError (naming ``right`` or ``left``) unless both are colour (H, W, 3) uint8
        images of the calibration's sizes."""
        for image, name, camera in ((right_bgr, "right", self.rig.cam1),
                                    (left_bgr, "left", self.rig.cam2)):
            if not (isinstance(image, np.ndarray) and image.dtype == np.uint8 and
                    image.ndim == 3 and image.shape[2] == 3):
                got = (f"{image.dtype} {image.shape}" if isinstance(image, np.ndarray)
                       else type(image).__name__)
                raise InputError(name, f"expected a colour (H, W, 3) uint8 image, got {got}")
            camera.check_image(image, name)

    def _locator(self, identifier: Identifier, name: str) -> Locator:
        """Model ``name``'s prepared Locator (prepared now when not held); NotFound for a
        name the library does not hold, also one removed while it was being loaded."""
        since = self._changes
        try:
            return identifier.locator(name)
        except KeyError:         # removed since the caller looked
            pass
        except InputError:       # its file went: removed or replaced meanwhile?
            if not self._wait_for_writers(since):
                raise
            if name in identifier.entries:
                return identifier.locator(name)
        raise NotFound("model", f"no model named {name!r}")

    def locator(self, name: str) -> Locator:
        """Model ``name``'s prepared Locator; NotFound for a name the library does not
        hold."""
        identifier = self.identifier
        if name not in identifier.entries:
            raise NotFound("model", f"no model named {name!r}")
        return self._locator(identifier, name)

    def locate(self, model: str, right: bytes, left: bytes, seed: int | None = None
               ) -> dict[str, Any]:
        """``locate --json``'s object for ``model`` in the uploaded pair (image files), plus
        ``id`` and ``pose_stamped``."""
        if model not in self.identifier.entries:
            raise NotFound("model", f"no model named {model!r}")
        return self.locate_pair(model, *self.decode_pair(right, left), seed)

    def locate_pair(self, model: str, right_bgr: NDArray[np.uint8],
                    left_bgr: NDArray[np.uint8], seed: int | None = None, *,
                    frame: dict[str, Any] | None = None, stamp_s: float | None = None
                    ) -> dict[str, Any]:
        """``locate --json``'s object for ``model`` in a pair of BGR (H, W, 3) uint8 views,
        plus ``id`` and ``pose_stamped``; the pair is kept for the result's overlay.

        Parameters
        ----------
        model : str
        right_bgr, left_bgr : ndarray (H, W, 3) uint8
            Camera 1's and camera 2's views.
        seed : int, optional
        frame : dict, optional
            Fields added to the answer (a grabbed pair's ``frame_t_s``, ...).
        stamp_s : float, optional
            ``pose_stamped``'s stamp, unix s (default: now; a grabbed pair's time).
        """
        identifier = self.identifier
        if model not in identifier.entries:
            raise NotFound("model", f"no model named {model!r}")
        self.check_pair(right_bgr, left_bgr)
        locator = self._locator(identifier, model)
        result = locator(right_bgr, left_bgr, rng=seed)
        answer = result.to_json_dict()
        answer["pose_stamped"] = pose_stamped(result.T_cam1_model,
                                              time.time() if stamp_s is None else stamp_s)
        answer.update(frame or {})
        caption = (f"{model}: {'found' if result.found else 'NOT found'}  score "
                   f"{result.score:.2f}  {result.seconds * 1000:.0f} ms")
        self.results.add("locate", answer, partial(_pair_png, right_bgr, left_bgr, caption,
                                                   locator.model, result.A_cam1_model,
                                                   self.rig))
        return answer

    def identify(self, right: bytes, left: bytes, seed: int | None = None, *,
                 every: bool = False) -> dict[str, Any]:
        """``identify --json``'s object for the uploaded pair (image files), plus ``id`` and
        ``pose_stamped`` (null when no model is on the table); ``every``: ``identify --all
        --json``'s."""
        self.ready()
        return self.identify_pair(*self.decode_pair(right, left), seed, every=every)

    def _identified(self, identifier: Identifier, right_bgr: NDArray[np.uint8],
                    left_bgr: NDArray[np.uint8], seed: int | None, every: bool) -> Any:
        since = self._changes
        call = identifier.all if every else identifier
        try:
            return call(right_bgr, left_bgr, rng=seed)
        except (KeyError, InputError):
            # a model screened in was removed (or replaced) before it could be loaded: once
            # more on the library as it is now
            if not self._wait_for_writers(since):
                raise
            return call(right_bgr, left_bgr, rng=seed)

    def identify_pair(self, right_bgr: NDArray[np.uint8], left_bgr: NDArray[np.uint8],
                      seed: int | None = None, *, frame: dict[str, Any] | None = None,
                      stamp_s: float | None = None, every: bool = False) -> dict[str, Any]:
        """``identify --json``'s object for a pair of BGR (H, W, 3) uint8 views, plus ``id``
        and ``pose_stamped`` (null when no model is on the table); ``frame`` and ``stamp_s``
        as for :meth:`locate_pair`; ``every``: every garment (``identify --all --json``'s
        object; ``pose_stamped`` that of the garment to pick first)."""
        identifier = self.identifier
        self.check_pair(right_bgr, left_bgr)
        if every:
            return self._identified_all(identifier, right_bgr, left_bgr, seed, frame, stamp_s)
        result = self._identified(identifier, right_bgr, left_bgr, seed, False)
        answer = result.to_json_dict()
        best = result.best
        answer["pose_stamped"] = (
            pose_stamped(best.T_cam1_model, time.time() if stamp_s is None else stamp_s)
            if result.found and best is not None else None)
        answer.update(frame or {})
        model: PhotoModel | None = None
        A = None
        if best is not None:
            caption = (f"{best.model}: {'found' if result.found else 'NOT found'}  score "
                       f"{best.score:.2f}  {result.seconds * 1000:.0f} ms")
            held = identifier.prepared.peek(best.model)   # just verified: held but for a race
            if held is not None:
                model, A = held.model, best.A_cam1_model
        else:
            caption = "no model of the library in view"
        self.results.add("identify", answer, partial(_pair_png, right_bgr, left_bgr, caption,
                                                     model, A, self.rig))
        return answer

    def _identified_all(self, identifier: Identifier, right_bgr: NDArray[np.uint8],
                        left_bgr: NDArray[np.uint8], seed: int | None,
                        frame: dict[str, Any] | None, stamp_s: float | None
                        ) -> dict[str, Any]:
        result = self._identified(identifier, right_bgr, left_bgr, seed, True)
        answer = result.to_json_dict()
        first = result.first
        answer["pose_stamped"] = (
            None if first is None else
            pose_stamped(first.result.T_cam1_model, time.time() if stamp_s is None else stamp_s))
        answer.update(frame or {})
        drawn = []
        for g in (result.garments[i] for i in result.pick_order):
            held = identifier.prepared.peek(g.model)
            if held is not None:
                drawn.append((held.model, g.result.A_cam1_model,
                               f"{g.pick_rank + 1}: {g.model} {g.result.score:.2f}"))
        caption = (f"{len(result.garments)} garment(s)  {result.seconds * 1000:.0f} ms"
                   if result.garments else "no model of the library in view")
        self.results.add("identify", answer, partial(_table_png, right_bgr, left_bgr, caption,
                                                     drawn, self.rig))
        return answer

    # --- the camera source ------------------------------------------------------------------

    def attach_source(self, source: str | Callable[[], CameraSource]) -> None:
        """Give the service a camera source (replacing one it has): a spec
        (:func:`~photomodel.service._source.open_source` with this rig and
        ``config.max_skew_ms``) or a function that opens one (called now, and again to
        re-open it after a stop). Errors opening it reach the caller."""
        if isinstance(source, str):
            from photomodel.service._source import open_source

            opener = partial(open_source, source, self.rig, max_skew_ms=self.config.max_skew_ms)
        else:
            opener = source
        link = SourceLink(opener)
        old, self.source = self.source, link
        if old is not None:
            old.close()

    def grab(self) -> StereoGrab:
        """A fresh pair from the camera source (Conflict without one; SourceError, HTTP
        503, when it is down or refuses the pair)."""
        link = self.source
        if link is None:
            raise Conflict("source", "this service has no camera source (start it with "
                                     "--source sim, replay:DIR or opencv:R,L)")
        return link.grab()

    def _grabbed(self) -> tuple[StereoGrab, dict[str, Any]]:
        t0 = time.perf_counter()
        grab = self.grab()
        link = self.source
        frame = {"frame_t_s": grab.t_s, "frame_index": grab.index,
                 "frame_skew_ms": grab.skew_ms, "source": link.name if link else None,
                 "grab_seconds": time.perf_counter() - t0}
        return grab, frame

    def trigger_locate(self, model: str, seed: int | None = None) -> dict[str, Any]:
        """:meth:`locate_pair` on a fresh pair from the camera source: the answer of
        ``/locate`` plus ``frame_t_s`` (the pair's time, unix s; also ``pose_stamped``'s
        stamp), ``frame_index``, ``frame_skew_ms``, ``source`` and ``grab_seconds``."""
        if model not in self.identifier.entries:      # before grabbing: 503 or 404 first
            raise NotFound("model", f"no model named {model!r}")
        grab, frame = self._grabbed()
        return self.locate_pair(model, grab.right_bgr, grab.left_bgr, seed, frame=frame,
                                stamp_s=grab.t_s)

    def trigger_identify(self, seed: int | None = None) -> dict[str, Any]:
        """:meth:`identify_pair` on a fresh pair from the camera source, with the fields
        :meth:`trigger_locate` adds."""
        self.ready()
        grab, frame = self._grabbed()
        return self.identify_pair(grab.right_bgr, grab.left_bgr, seed, frame=frame,
                                  stamp_s=grab.t_s)

    def record(self, frames: int) -> dict[str, Any]:
        """Write the source's next ``frames`` pairs as a recording (:class:`Recorder`);
        Conflict without a source or while another recording runs."""
        link = self.source
        if link is None:
            raise Conflict("source", "this service has no camera source to record (start it "
                                     "with --source)")
        return self.recorder.record(link, frames)

    def close(self) -> None:
        """Release the camera source."""
        self.feed.close()
        if self.source is not None:
            self.source.close()

    def health(self) -> dict[str, Any]:
        """``/health``'s object; ``"status": "degraded"`` (with ``detail``) when warmed up
        but the camera source is down, and ``source`` (its state, or null without one)."""
        from photomodel import __version__

        stats = self.prepared_stats()
        status, detail = self.status, self.detail
        link = self.source
        source = None if link is None else link.health()
        if status == "ok" and source is not None and source["state"] != "ok":
            status, detail = "degraded", f"camera source {source['name']} {source['detail']}"
        return {"status": status, "models": self.model_count(), "version": __version__,
                "detail": detail, "searches": self.searches,
                "uptime_s": round(time.time() - self.started_s, 1),
                "prepared": 0 if stats is None else stats.prepared,
                "prepared_max": self.config.prepared_models, "source": source,
                "tls": self.config.tls, "warning": exposure_warning(self.config)}


def _taken(name: str) -> Conflict:
    return Conflict("name", f"the library already holds a model named {name!r} (send "
                            "replace=true to replace it)")


def _summary(entry: LibraryEntry) -> dict[str, Any]:
    """``/models``' object of one model: the index's fields but the descriptor (what
    identification screens with, about 1 kB), and the preview's URL."""
    return {"name": entry.name, **dataclasses.replace(entry, descriptor=None).to_json_dict(),
            "preview": f"models/{quote(entry.name, safe='')}/preview.png"}


def exposure_warning(config: ServiceConfig) -> str | None:
    """The warning of a service that listens beyond this machine without TLS, or None."""
    from photomodel.service._server import is_loopback

    if config.tls or is_loopback(config.host):
        return None
    return (f"listening on {config.host} without TLS: tokens and images cross the network "
            "in clear (give --tls-cert and --tls-key; photomodel certs makes them)")


def _tokens(config: ServiceConfig) -> Callable[[], TokenBook] | None:
    """What gives the service's current credentials, or None (no authentication)."""
    if config.token_file is not None:
        return TokenFile(config.token_file).book
    if config.token is not None:
        book = TokenBook.single(config.token)
        return lambda: book
    return None


def read_token(path: Path) -> str:
    """The bearer token in ``path`` (one line, at least 16 characters, no spaces)."""
    from photomodel._limits import read_capped

    return check_token(read_capped(path, "token file", 4096).decode("utf-8", "replace")
                       .strip(), path)
