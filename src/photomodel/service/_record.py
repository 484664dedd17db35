"""``POST /record``: the next pairs of the camera source written as a folder that ``replay:``,
``photomodel calibrate stereo --pairs`` and ``photomodel track --frames`` read.

Layout (written in a hidden temporary folder, then renamed, so that a half-written
recording never shows)::

    RECORD_DIR/<name>/000000/right.png, left.png   camera 1, camera 2
    RECORD_DIR/<name>/meta.json                    {"fps", "frames": {"000000": {"t_s", ...}}}
    RECORD_DIR/<name>/stereo.yaml                  the service's calibration, as served
"""

from __future__ import annotations

import json
import os
import shutil
import threading
import time
import uuid
from pathlib import Path
from typing import Any

import cv2

from photomodel.errors import InputError
from photomodel.service._source_link import SourceLink

__all__ = ["MAX_RECORD_FRAMES", "Recorder"]

MAX_RECORD_FRAMES = 10_000
"""Most pairs one recording takes (about 9 GB of PNG with 640 x 480 cameras)."""

_PNG_FAST = [cv2.IMWRITE_PNG_COMPRESSION, 1]   # a quick encode: the source keeps running


class Recorder:
    """Writes recordings under ``root``, one at a time.

    Parameters
    ----------
    root : Path
        The folder recordings go to (``--record-dir``; made when first needed).
    stereo : Path or None
        The calibration copied into each recording.
    """

    def __init__(self, root: Path, stereo: Path | None = None) -> None:
        self.root = Path(root)
        self.stereo = stereo
        self._busy = threading.Lock()

    def record(self, link: SourceLink, frames: int) -> dict[str, Any]:
        """Grab the next ``frames`` pairs of ``link`` and write them as a recording.

        Returns
        -------
        dict
            ``{"path", "name", "frames", "fps", "seconds", "source", "first_t_s",
            "last_t_s"}``: where it was written (absolute), the measured rate of the pairs
            written, the recording's wall time and the first and last pair's times (unix s).

        Raises
        ------
        InputError
            ``frames`` out of 1 to :data:`MAX_RECORD_FRAMES`, the folder cannot be written;
            :class:`~photomodel.service._cell.Conflict` while another recording runs;
            :class:`~photomodel.service._source.SourceError` when the source fails meanwhile
            (nothing is left behind).
        """
        from photomodel.service._cell import Conflict

        if isinstance(frames, bool) or not isinstance(frames, int) or \
                not 1 <= frames <= MAX_RECORD_FRAMES:
            raise InputError("frames", f"expected 1 to {MAX_RECORD_FRAMES} pairs, got {frames!r}")
        if not self._busy.acquire(blocking=False):
            raise Conflict("record", "another recording is running; wait for it to finish")
        try:
            return self._record(link, frames)
        finally:
            self._busy.release()

    def _record(self, link: SourceLink, frames: int) -> dict[str, Any]:
        name = time.strftime("%Y%m%d-%H%M%S", time.gmtime()) + "-" + uuid.uuid4().hex[:6]
        tmp = self.root / f".{name}.tmp"
        try:
            tmp.mkdir(parents=True)
        except OSError as exc:
            raise InputError("--record-dir", f"{self.root}: cannot write a recording here "
                                             f"({exc.strerror})") from None
        t0 = time.perf_counter()
        try:
            stamps: dict[str, dict[str, Any]] = {}
            first_t_s = None
            for k in range(frames):
                grab = link.grab()
                first_t_s = grab.t_s if first_t_s is None else first_t_s
                folder = tmp / f"{k:06d}"
                folder.mkdir()
                for view, image in (("right.png", grab.right_bgr), ("left.png", grab.left_bgr)):
                    if not cv2.imwrite(str(folder / view), image, _PNG_FAST):
                        raise InputError("--record-dir", f"{folder / view}: cannot be written")
                stamps[folder.name] = {"t_s": grab.t_s - first_t_s, "t_unix_s": grab.t_s,
                                       "t_right_s": grab.t_right_s, "t_left_s": grab.t_left_s,
                                       "index": grab.index}
            assert first_t_s is not None
            span_s = grab.t_s - first_t_s
            fps = (frames - 1) / span_s if frames > 1 and span_s > 0 else (link.fps or 30.0)
            meta = {"format": "photomodel-recording", "format_version": 1, "fps": fps,
                    "source": link.name, "source_fps": link.fps,
                    "created_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                    "camera1": "right.png", "frames": stamps}
            (tmp / "meta.json").write_text(json.dumps(meta, indent=1))
            if self.stereo is not None:
                shutil.copyfile(self.stereo, tmp / "stereo.yaml")
            final = self.root / name
            os.rename(tmp, final)
        except BaseException as exc:
            shutil.rmtree(tmp, ignore_errors=True)
            if isinstance(exc, OSError):
                raise InputError("--record-dir", f"{self.root}: the recording could not be "
                                                 f"written ({exc.strerror or exc})") from None
            raise
        return {"path": str(final.resolve()), "name": name, "frames": frames, "fps": fps,
                "seconds": time.perf_counter() - t0, "source": link.name,
                "first_t_s": first_t_s, "last_t_s": grab.t_s}
