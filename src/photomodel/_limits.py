"""Bounds on what the loaders accept: one place, so that the image, calibration and model
loaders (and a service that hands them a client's upload) agree on them.

Every bound is checked on what a file *declares* (an image header's size, a zip member's
uncompressed size, an array header's shape) before anything of that size is allocated, so a
small file that claims to be huge costs no memory.

=============================  ==========  ====================================================
bound                          value       why
=============================  ==========  ====================================================
``MAX_IMAGE_PIXELS``           50 MP       4 x a 12 MP camera; decodes to 150 MB as 8-bit
                                           colour (about twice that at the decoder's peak),
                                           400 MB as 16-bit RGBA (the worst case)
``MAX_IMAGE_SIDE_PX``          32767 px    OpenCV's remap (used on the photo and the scene
                                           images) takes no larger side
``MAX_IMAGE_FILE_BYTES``       256 MiB     an uncompressed 32-bit BMP of 50 MP is 200 MB
``MAX_CALIBRATION_FILE_BYTES`` 1 MiB       a stereo calibration is about 1-3 kB
``FOCAL_PX_RANGE``             1-1e5 px    a focal length outside it is a unit or typing
                                           mistake (the rig's cameras: about 800 px)
``MAX_FOCAL_PER_SIDE``         20          f at most 20 x the image's larger side (a field
                                           of view of at least 2.9 deg) when the size is known
``MAX_PRINCIPAL_POINT_PX``     1e5 px      |cx|, |cy|
``MAX_DISTORTION_COEFF``       1e4         |k1| ... |s4| (rational models reach tens)
``MAX_DISTANCE_MM``            1e5 mm      camera to model plane (the paper's: 400 mm)
``MAX_BASELINE_MM``            1e5 mm      |T| of the stereo rig (the paper's: about 120 mm)
``METRES_SUSPECT_MM``          1 mm        a baseline below it was almost surely given in
                                           metres: a warning, not an error
``MAX_MODEL_EXTENT_MM``        2000 mm     a garment's outline (the paper's: up to 250 x 200)
``MAX_MODEL_POINTS``           1 000 000   points in S_in, S_out or the outline (a 250 x 200 mm
                                           garment at the default 3 mm step has about 6000)
``MAX_MODEL_BYTES``            ~285 MB     a model's arrays uncompressed: its photo crop and
                                           mask (4 B/px) of at most ``MAX_IMAGE_PIXELS`` (a
                                           model photo is read through the image loader), its
                                           point arrays (84 B per point), 1 MiB for metadata
``MAX_MODEL_FILE_BYTES``       + 1 MiB     a stored (uncompressed) archive is no larger
``MAX_MODEL_META_BYTES``       1 MiB       the JSON metadata (a model's: about 1 kB)
=============================  ==========  ====================================================

:func:`checked_size` and :func:`read_capped` are the loaders' first step on a file.

For scale: the largest model of the paper's study, a 250 x 200 mm garment photographed by the
simulated model station (f = 760 px at 400 mm: 1.9 px/mm), is a 475 x 380 px crop, about
0.9 MB uncompressed; a 6 GB zip bomb is refused from its 5.9 MB file's directory.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = [
    "FOCAL_PX_RANGE",
    "MAX_FOCAL_PER_SIDE",
    "MAX_BASELINE_MM",
    "MAX_CALIBRATION_FILE_BYTES",
    "MAX_DISTANCE_MM",
    "MAX_DISTORTION_COEFF",
    "MAX_IMAGE_FILE_BYTES",
    "MAX_IMAGE_PIXELS",
    "MAX_IMAGE_SIDE_PX",
    "MAX_MODEL_BYTES",
    "MAX_MODEL_EXTENT_MM",
    "MAX_MODEL_FILE_BYTES",
    "MAX_MODEL_META_BYTES",
    "MAX_MODEL_POINTS",
    "MAX_PRINCIPAL_POINT_PX",
    "METRES_SUSPECT_MM",
    "checked_size",
    "read_capped",
]

MiB = 1 << 20

MAX_IMAGE_PIXELS = 50_000_000
MAX_IMAGE_SIDE_PX = 32_767
MAX_IMAGE_FILE_BYTES = 256 * MiB

MAX_CALIBRATION_FILE_BYTES = 1 * MiB
FOCAL_PX_RANGE = (1.0, 1e5)
MAX_FOCAL_PER_SIDE = 20.0
MAX_PRINCIPAL_POINT_PX = 1e5
MAX_DISTORTION_COEFF = 1e4
MAX_DISTANCE_MM = 1e5
MAX_BASELINE_MM = 1e5
METRES_SUSPECT_MM = 1.0

MAX_MODEL_EXTENT_MM = 2000.0
MAX_MODEL_POINTS = 1_000_000
MAX_MODEL_META_BYTES = 1 * MiB
# photo crop (3 B/px) + mask (1 B/px); S_in (24 B) + its hsv (12 B), S_out (24 B), outline
# (24 B) per point; the metadata.
MAX_MODEL_BYTES = 4 * MAX_IMAGE_PIXELS + 84 * MAX_MODEL_POINTS + MAX_MODEL_META_BYTES
MAX_MODEL_FILE_BYTES = MAX_MODEL_BYTES + MiB


def checked_size(path: str | os.PathLike[str], kind: str, limit: int, hint: str = "") -> int:
    """The size of the regular file ``path``, after the checks every loader makes first.

    Raises
    ------
    InputError
        The file is missing (or not a regular file), cannot be read, or is larger than
        ``limit`` bytes; the message names ``kind`` ("image file", ...) and adds ``hint``.
    """
    from photomodel.errors import InputError

    p = Path(path)
    try:
        if p.is_dir():
            raise InputError(p, f"is a directory, not the {kind}")
        if not p.is_file():
            raise InputError(p, f"{kind} not found" if not p.exists()
                             else f"is not a regular file, not the {kind}")
        size = p.stat().st_size
    except OSError as exc:
        raise InputError(p, f"cannot read the {kind} ({exc.strerror or exc})") from None
    if size > limit:
        raise InputError(p, f"{kind} is {_megabytes(size)}, larger than the {_megabytes(limit)} "
                            f"photomodel reads{hint}")
    return size


_CHUNK_BYTES = 1 << 20


def read_capped(path: str | os.PathLike[str], kind: str, limit: int, hint: str = "") -> bytes:
    """The bytes of ``path``: at most ``limit`` of them are ever read (a file that grows
    after :func:`checked_size` looked is refused all the same)."""
    from photomodel.errors import InputError

    checked_size(path, kind, limit, hint)
    try:
        with open(path, "rb") as fh:  # in chunks: read(limit + 1) reserves limit bytes at once
            chunks, total = [], 0
            while total <= limit and (chunk := fh.read(min(_CHUNK_BYTES, limit + 1 - total))):
                chunks.append(chunk)
                total += len(chunk)
            data = b"".join(chunks)
    except OSError as exc:
        raise InputError(path, f"cannot read the {kind} ({exc.strerror or exc})") from None
    if len(data) > limit:
        raise InputError(path, f"{kind} is larger than the {_megabytes(limit)} photomodel "
                               f"reads{hint}")
    return data


def _megabytes(n: int) -> str:
    return f"{n / 1e6:.1f} MB" if n < 10e6 else f"{n / 1e6:.0f} MB"
