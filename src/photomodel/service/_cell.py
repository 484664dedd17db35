"""``CellService``: the state of one resident service (calibration, library, a prepared
``Locator`` per model, recent results), independent of HTTP: the app calls its methods from
worker threads."""

from __future__ import annotations

import logging
import threading
import time
import warnings
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
from photomodel.identify import Identifier, IdentifyConfig
from photomodel.image import decode_color_image, decode_color_images
from photomodel.library import ModelLibrary, check_model_name
from photomodel.library._library import LibraryEntry
from photomodel.locate import Locator, draw_overlay, load_threshold
from photomodel.model import PhotoModel, build_model
from photomodel.service._results import Latencies, ResultRing
from photomodel.service._ros import pose_stamped

__all__ = ["CellService", "Conflict", "NotFound", "ServiceConfig", "Unavailable", "read_token"]

log = logging.getLogger("photomodel.service")

MiB = 1 << 20


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
        When set, every request needs ``Authorization: Bearer <token>``.
    threshold : Path or None
        Threshold file (default: the library's ``threshold.json``, else the user's).
    """

    stereo: Path
    models: Path
    camera: Path | None = None
    searches: int = 2
    results_kept: int = 20
    max_upload_bytes: int = 32 * MiB
    token: str | None = None
    threshold: Path | None = None

    def __post_init__(self) -> None:
        if not 1 <= self.searches <= 64:
            raise ValueError(f"searches: expected 1 to 64 at once, got {self.searches}")
        if not 1 <= self.results_kept <= 1000:
            raise ValueError(f"results_kept: expected 1 to 1000, got {self.results_kept}")
        if not MiB <= self.max_upload_bytes <= 1024 * MiB:
            raise ValueError("max_upload_bytes: expected 1 MiB to 1 GiB, got "
                             f"{self.max_upload_bytes}")


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


class CellService:
    """One cell's resident state.

    Made from a :class:`ServiceConfig` (reads the calibrations; a bad file is an InputError
    at start), then :meth:`warm` (compile and load the kernels, prepare every model of the
    library) before :attr:`status` turns ``"ok"``. Its methods may run in several threads at
    once; registrations and removals are serialised.
    """

    def __init__(self, config: ServiceConfig) -> None:
        self.config = config
        self.rig: StereoRig = load_stereo(config.stereo)
        self.camera: PinholeCamera | None = None
        self.distance_mm = 400.0
        if config.camera is not None:
            self.camera = load_camera(config.camera)
            self.distance_mm = load_distance_mm(config.camera) or 400.0
        self.library = ModelLibrary(config.models, create=True)
        self.min_score = load_threshold(config.threshold, library=self.library.root).min_score
        self.results = ResultRing(config.results_kept)
        self.latencies = Latencies(100)
        self.status = "warming"
        self.detail = "starting"
        self.started_s = time.time()
        self.warm_seconds: float | None = None
        self.searches = config.searches
        self._locators: dict[str, Locator] = {}
        self._entries: dict[str, LibraryEntry] = {}
        self._previews: dict[str, bytes] = {}
        self._identifier: Identifier | None = None
        self._lock = threading.Lock()        # the maps above and the identifier
        self._writing = threading.Lock()     # registrations and removals, one at a time

    # --- warming ---------------------------------------------------------------------------

    def warm(self, progress: Callable[[str], None] | None = None) -> None:
        """Compile (when not cached) and load every kernel, then prepare every model of the
        library; :attr:`status` is ``"ok"`` after, ``"failed"`` (with :attr:`detail`) when
        anything went wrong."""
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
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                models, skipped = self.library.load()
            for s in skipped:
                say(f"serve: {s}")
            for w in caught:
                say(f"serve: {w.message}")
            entries = {e.name: e for e in self.library.scan().entries}
            for i, model in enumerate(models, 1):
                self.detail = f"preparing {model.name} ({i}/{len(models)})"
                locator = self._prepare(model)
                with self._lock:
                    self._locators[model.name] = locator
                    self._entries[model.name] = entries[model.name]
            with self._lock:
                self._rebuild_identifier()
            self.warm_seconds = time.perf_counter() - t0
            self.status, self.detail = "ok", "ready"
            say(f"serve: ready in {self.warm_seconds:.1f} s: {len(models)} models, "
                f"{self.searches} searches at once")
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

    def _prepare(self, model: PhotoModel) -> Locator:
        """A Locator of ``model`` for the rig, with one search on a blank pair so that the
        first request finds everything made."""
        locator = Locator(model, self.rig, min_score=self.min_score)
        (w1, h1), (w2, h2) = self.rig.cam1.image_size, self.rig.cam2.image_size
        if w1 and h1 and w2 and h2:
            locator(np.zeros((h1, w1, 3), np.uint8), np.zeros((h2, w2, 3), np.uint8), rng=0)
        return locator

    def _rebuild_identifier(self) -> None:
        """A new Identifier over the prepared locators (held: ``self._lock``)."""
        locators = list(self._locators.values())
        self._identifier = Identifier(locators, self.rig,
                                      config=IdentifyConfig(min_score=self.min_score))

    def ready(self) -> None:
        """Raise :class:`Unavailable` unless warmed up."""
        if self.status != "ok":
            raise Unavailable("service", f"{self.status}: {self.detail}")

    # --- the library -------------------------------------------------------------------------

    def models(self) -> list[dict[str, Any]]:
        """Summaries of the models the service can locate, by name."""
        with self._lock:
            entries = sorted(self._entries.values(), key=lambda e: e.name)
        return [_summary(e) for e in entries]

    def register(self, name: str, photo: bytes, background: bytes,
                 distance_mm: float | None = None, *, replace: bool = False) -> dict[str, Any]:
        """Build a photo-model from its two photos (the model station's ``--camera``), add it
        to the library and prepare it; returns its summary."""
        self.ready()
        if self.camera is None:
            raise InputError("photo", "registering a garment needs the service started with "
                                      "--camera (the model station's calibration)")
        check_model_name(name, "name")
        if distance_mm is not None and not (np.isfinite(distance_mm) and
                                            0 < distance_mm <= 1e5):
            raise InputError("distance_mm", f"expected a distance in (0, 100000] mm, got "
                                            f"{distance_mm:g}")
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
        with self._writing:
            with self._lock:
                taken = name in self._locators
            if taken and not replace:
                raise Conflict("name", f"the library already holds a model named {name!r} "
                                       "(send replace=true to replace it)")
            entry = self.library.add_model(model, replace=replace)
            locator = self._prepare(model)
            with self._lock:
                self._locators[name] = locator
                self._entries[name] = entry
                self._previews.pop(name, None)
                self._rebuild_identifier()
        log.info("serve: registered %s (%.0f x %.0f mm)", name, *entry.size_mm)
        return _summary(entry)

    def remove(self, name: str) -> dict[str, Any]:
        """Delete model ``name`` from the library and from memory; returns its summary."""
        self.ready()
        with self._writing:
            with self._lock:
                if name not in self._locators:
                    raise NotFound("model", f"no model named {name!r}")
            entry = self.library.remove(name)
            with self._lock:
                self._locators.pop(name, None)
                self._entries.pop(name, None)
                self._previews.pop(name, None)
                self._rebuild_identifier()
        return _summary(entry)

    def preview_png(self, name: str) -> bytes:
        """The model's photo crop with its silhouette outlined (PNG)."""
        with self._lock:
            locator = self._locators.get(name)
            png = self._previews.get(name)
        if locator is None:
            raise NotFound("model", f"no model named {name!r}")
        if png is None:
            model = locator.model
            image = model.photo_bgr.copy()
            contours, _ = cv2.findContours(model.mask.astype(np.uint8), cv2.RETR_EXTERNAL,
                                           cv2.CHAIN_APPROX_NONE)
            cv2.drawContours(image, contours, -1, (0, 255, 255), 1, cv2.LINE_AA)
            png = _png(image)
            with self._lock:
                self._previews[name] = png
        return png

    # --- searches ----------------------------------------------------------------------------

    def _pair(self, right: bytes, left: bytes) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
        right_bgr, left_bgr = decode_color_images([(right, "right"), (left, "left")])
        self.rig.cam1.check_image(right_bgr, "right")
        self.rig.cam2.check_image(left_bgr, "left")
        return right_bgr, left_bgr

    def locate(self, model: str, right: bytes, left: bytes, seed: int | None = None
               ) -> dict[str, Any]:
        """``locate --json``'s object for ``model`` in the pair, plus ``id`` and
        ``pose_stamped``."""
        self.ready()
        with self._lock:
            locator = self._locators.get(model)
        if locator is None:
            raise NotFound("model", f"no model named {model!r}")
        right_bgr, left_bgr = self._pair(right, left)
        result = locator(right_bgr, left_bgr, rng=seed)
        answer = result.to_json_dict()
        answer["pose_stamped"] = pose_stamped(result.T_cam1_model, time.time())
        caption = (f"{model}: {'found' if result.found else 'NOT found'}  score "
                   f"{result.score:.2f}  {result.seconds * 1000:.0f} ms")
        self.results.add("locate", answer, partial(_pair_png, right_bgr, left_bgr, caption,
                                                   locator.model, result.A_cam1_model,
                                                   self.rig))
        return answer

    def identify(self, right: bytes, left: bytes, seed: int | None = None) -> dict[str, Any]:
        """``identify --json``'s object for the pair, plus ``id`` and ``pose_stamped``
        (null when no model is on the table)."""
        self.ready()
        with self._lock:
            identifier = self._identifier
            locators = dict(self._locators)
        assert identifier is not None
        right_bgr, left_bgr = self._pair(right, left)
        result = identifier(right_bgr, left_bgr, rng=seed)
        answer = result.to_json_dict()
        best = result.best
        answer["pose_stamped"] = (pose_stamped(best.T_cam1_model, time.time())
                                  if result.found and best is not None else None)
        if best is not None:
            caption = (f"{best.model}: {'found' if result.found else 'NOT found'}  score "
                       f"{best.score:.2f}  {result.seconds * 1000:.0f} ms")
            model = locators[best.model].model if best.model in locators else None
            A = best.A_cam1_model if model is not None else None
        else:
            caption, model, A = "no model of the library in view", None, None
        self.results.add("identify", answer, partial(_pair_png, right_bgr, left_bgr, caption,
                                                     model, A, self.rig))
        return answer

    def health(self) -> dict[str, Any]:
        """``/health``'s object."""
        from photomodel import __version__

        with self._lock:
            n = len(self._locators)
        return {"status": self.status, "models": n, "version": __version__,
                "detail": self.detail, "searches": self.searches,
                "uptime_s": round(time.time() - self.started_s, 1)}


def _summary(entry: LibraryEntry) -> dict[str, Any]:
    return {"name": entry.name, **entry.to_json_dict(),
            "preview": f"models/{quote(entry.name, safe='')}/preview.png"}


def read_token(path: Path) -> str:
    """The bearer token in ``path`` (one line, at least 16 characters, no spaces)."""
    from photomodel._limits import read_capped

    text = read_capped(path, "token file", 4096).decode("utf-8", "replace").strip()
    if len(text) < 16 or any(c.isspace() or not c.isprintable() for c in text):
        raise InputError(path, "expected one token of at least 16 printable characters "
                               "without spaces")
    return text
