"""``replay:DIR``: recorded stereo pairs played back as a camera at their frame rate, looping.

``DIR`` is a sequence (``DIR/<frame>/right.png, left.png``, as ``photomodel simulate
--sequences`` and ``POST /record`` write, with ``fps`` in ``truth.json`` or ``meta.json``)
or a dataset (``DIR/scenes/<id>/right.png, left.png``); frames in name order. The frame rate
is the folder's ``fps``, else 30.

Decoded pairs are kept (up to :data:`CACHE_BYTES`, the first ones of the loop; a pair is
known by its two files' real paths, sizes and modification times), so that a loop is decoded
once, as a camera hands over pixels without decoding; a file that changes is read again.

The replay runs on the source's clock like a free-running camera: frame ``k`` (of the loop
that never ends) is exposed at ``t0 + k / fps``; a grab answers the newest frame not given
yet, waiting for the next one when the newest was given already, so a slow reader skips
frames as it would with a camera. A streaming grab (``newest=False``) answers the oldest
frame not given yet among the last :data:`BUFFERS`, as a camera's driver hands over its
queued buffers. Views are read from disk at each grab: a folder removed
while the service runs stops the source (:class:`SourceError`), and the service re-opens it
when it is back.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any

from photomodel.camera import StereoRig
from photomodel.errors import InputError
from photomodel.service._source import Clock, SourceError, StereoGrab

__all__ = ["DEFAULT_FPS", "ReplaySource", "replay_frames"]

DEFAULT_FPS = 30.0
"""Frame rate of a folder that gives none."""

BUFFERS = 8
"""Frames a streaming grab may fall behind before frames are lost (a driver's buffer count)."""

CACHE_BYTES = 256 << 20
"""Most bytes of decoded pairs a replay keeps (about 140 VGA pairs)."""

TIMING_FILES = ("meta.json", "truth.json")
_MAX_TIMING_BYTES = 64 << 20


def replay_frames(root: Path) -> list[Path]:
    """The pair folders of ``root`` in name order: ``root/<frame>/`` or, for a dataset,
    ``root/scenes/<id>/``.

    Raises
    ------
    SourceError
        ``root`` is not a folder, holds no pair, or a pair lacks one of its two views.
    """
    name = f"replay:{root}"
    if not root.is_dir():
        raise SourceError(name, "no such folder (expected DIR/<frame>/right.png and left.png, "
                                "or a dataset's DIR/scenes/<id>/)")
    base = root / "scenes" if (root / "scenes").is_dir() else root
    try:
        folders = sorted(p for p in base.iterdir()
                         if p.is_dir() and not p.name.startswith(".")
                         and ((p / "right.png").exists() or (p / "left.png").exists()))
    except OSError as exc:
        raise SourceError(name, f"cannot list the folder ({exc.strerror})") from None
    if not folders:
        raise SourceError(name, "no stereo pairs: expected sub-folders with right.png and "
                                "left.png")
    for folder in folders:
        for view in ("right.png", "left.png"):
            if not (folder / view).is_file():
                raise SourceError(name, f"pair {folder.name} lacks {view}")
    return folders


def folder_fps(root: Path) -> float:
    """The frame rate ``fps`` of ``root``'s meta.json or truth.json, else
    :data:`DEFAULT_FPS`; SourceError for a timing file that cannot be read or a rate that is
    not positive."""
    for name in TIMING_FILES:
        path = root / name
        if not path.is_file():
            continue
        try:
            if path.stat().st_size > _MAX_TIMING_BYTES:
                raise ValueError(f"larger than {_MAX_TIMING_BYTES >> 20} MiB")
            doc = json.loads(path.read_text(encoding="utf-8"))
            fps = doc.get("fps") if isinstance(doc, dict) else None
            if fps is None:
                continue
            fps = float(fps)
        except (OSError, ValueError, TypeError) as exc:
            raise SourceError(f"replay:{root}", f"{name}: unreadable ({exc})") from None
        if not (math.isfinite(fps) and 0.0 < fps <= 10_000.0):
            raise SourceError(f"replay:{root}", f"{name}: fps {fps:g} is not a frame rate "
                                                "(0 to 10000)")
        return fps
    return DEFAULT_FPS


class ReplaySource:
    """A folder of stereo pairs as a free-running camera (made by :meth:`open`).

    Attributes
    ----------
    name : str
    fps : float
    root : Path
    frames : list of Path
        The pair folders, played in this order, then again.
    """

    def __init__(self, root: Path, frames: list[Path], fps: float, clock: Clock) -> None:
        self.root = root
        self.name = f"replay:{root}"
        self.frames = frames
        self.fps: float | None = fps
        self._clock = clock
        self._t0_s = clock()
        self._last = -1
        self._cache: dict[tuple[Any, ...], tuple[Any, Any]] = {}
        self._cached_bytes = 0

    @classmethod
    def open(cls, args: str, rig: StereoRig, *, clock: Clock) -> ReplaySource:
        """Open ``replay:ARGS``; reads the first pair to check it against ``rig``."""
        root = Path(args).expanduser()
        frames = replay_frames(root)
        source = cls(root, frames, folder_fps(root), clock)
        right, left = source._read(frames[0])
        for camera, image, which in ((rig.cam1, right, "camera 1 (right)"),
                                     (rig.cam2, left, "camera 2 (left)")):
            try:
                camera.check_image(image, f"{frames[0].name}: {which}")
            except InputError as exc:
                raise SourceError(source.name, str(exc)) from None
        return source

    def _read(self, folder: Path) -> tuple[Any, Any]:
        from photomodel.image import decode_color_images

        try:
            paths = [(folder / view).resolve(strict=True) for view in ("right.png", "left.png")]
            stats = [path.stat() for path in paths]
            key = tuple((str(path), st.st_size, st.st_mtime_ns)
                        for path, st in zip(paths, stats, strict=True))
            if (held := self._cache.get(key)) is not None:
                return held
            data = [path.read_bytes() for path in paths]
        except OSError as exc:
            raise SourceError(self.name, f"pair {folder.name}: cannot be read "
                                         f"({exc.strerror}): folder removed?") from None
        try:
            right, left = decode_color_images([(data[0], f"{folder.name}/right.png"),
                                               (data[1], f"{folder.name}/left.png")])
        except InputError as exc:
            # a damaged file: this pair is refused, the replay goes on
            raise SourceError(self.name, f"pair {folder.name}: {exc}", stopped=False) from None
        size = right.nbytes + left.nbytes
        if self._cached_bytes + size <= CACHE_BYTES:
            right.flags.writeable = left.flags.writeable = False    # shared by every grab
            self._cache[key] = (right, left)
            self._cached_bytes += size
        return right, left

    def grab(self, timeout_s: float, *, newest: bool = True) -> StereoGrab:
        fps = self.fps or DEFAULT_FPS
        now = self._clock()
        exposed = math.floor((now - self._t0_s) * fps)
        index = max(exposed if newest else exposed - BUFFERS + 1, self._last + 1)
        due_s = self._t0_s + index / fps
        wait_s = due_s - now
        if wait_s > timeout_s:
            raise SourceError(self.name, f"no frame within {timeout_s:g} s", stopped=False)
        if wait_s > 0.0:
            time.sleep(wait_s)
        self._last = index
        right, left = self._read(self.frames[index % len(self.frames)])
        return StereoGrab(right, left, due_s, due_s, index)

    def close(self) -> None:
        """Nothing is held open between grabs."""

    def describe(self) -> dict[str, Any]:
        return {"kind": "replay", "folder": str(self.root), "pairs": len(self.frames),
                "fps": self.fps}
