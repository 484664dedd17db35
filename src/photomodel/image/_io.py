"""Reading and writing images with errors that name the file.

:func:`read_color_image` is the one place that reads an image a user or a client gives
(PNG, BMP or JPEG, the formats of the contract). It reads at most
:data:`~photomodel._limits.MAX_IMAGE_FILE_BYTES`, parses the format's own header (PNG ``IHDR``
and chunk list, BMP info header, JPEG ``SOF`` segment) and refuses a file that claims more than
:data:`~photomodel._limits.MAX_IMAGE_PIXELS` (or a side over
:data:`~photomodel._limits.MAX_IMAGE_SIDE_PX`) or is cut short *before* OpenCV decodes it, so a
74-byte PNG that claims 60000 x 60000 pixels allocates nothing. Decoding is silent: OpenCV's
log is off and what libpng and libjpeg print on stderr while an image is decoded is caught and
turned into one :class:`~photomodel.errors.InputWarning` (damaged data that still decoded) or
the :class:`~photomodel.errors.InputError` (data that did not).
"""

from __future__ import annotations

import contextlib
import os
import re
import struct
import sys
import tempfile
import threading
import warnings
import zlib
from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel._files import write_atomic
from photomodel._limits import (
    MAX_IMAGE_FILE_BYTES,
    MAX_IMAGE_PIXELS,
    MAX_IMAGE_SIDE_PX,
    read_capped,
)
from photomodel.errors import InputError, InputWarning

__all__ = [
    "IMAGE_SUFFIXES",
    "decode_color_image",
    "decode_color_images",
    "read_color_image",
    "read_grey_image",
    "write_image",
]

IMAGE_SUFFIXES = (".png", ".bmp", ".jpg", ".jpeg")
"""File suffixes (lower case) of the image formats :func:`read_color_image` reads: PNG, BMP and
JPEG. Folders of images are listed by them, and an image a command writes takes one of them."""

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_PNG_BIT_DEPTHS = {0: (1, 2, 4, 8, 16), 2: (8, 16), 3: (1, 2, 4, 8), 4: (8, 16), 6: (8, 16)}
_PNG_MAX_CHUNKS = 100_000      # a 50 MP PNG in libpng's 8 kB IDAT chunks has about 25 000
_JPEG_MAX_SEGMENTS = 1_000     # segments before the frame header (a camera's: about 10)
_JPEG_MAX_SCANS = 1_000        # a progressive JPEG has about 10; thousands cost minutes
_JPEG_MARKER = re.compile(rb"\xff+[^\xff]")
_JPEG_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}
_DECODER_LINE = re.compile(
    r"^(libpng |Corrupt JPEG data|Premature end of JPEG|Warning: unknown JFIF|Invalid SOS|"
    r"Inconsistent progression|Unknown Adobe|Application transferred|\[ ?(WARN|ERROR|INFO)\b)")
_DAMAGE = re.compile(r"Corrupt JPEG|Premature end|IDAT|incomplete|extraneous", re.IGNORECASE)
_DECODE_LOCK = threading.Lock()  # one decode at a time may borrow file descriptor 2
_DECODER: ThreadPoolExecutor | None = None


def read_color_image(path: str | os.PathLike[str]) -> NDArray[np.uint8]:
    """Read a colour image (PNG, BMP or JPEG) as 8-bit BGR (H, W, 3).

    16-bit images are scaled to 8 bits (``value // 257``), an alpha channel is dropped.

    Raises
    ------
    InputError
        The file is missing, larger than ``MAX_IMAGE_FILE_BYTES``, not a PNG, BMP or JPEG,
        claims more than ``MAX_IMAGE_PIXELS``, is cut short or damaged so that it does not
        decode, or has no colour (hue needs colour).

    Warns
    -----
    InputWarning
        The image decoded although the decoder found damaged data (parts of it may be grey).
    """
    p = Path(path)
    return decode_color_image(read_capped(p, "image file", MAX_IMAGE_FILE_BYTES), p)


def decode_color_image(data: bytes, source: str | os.PathLike[str] = "image"
                       ) -> NDArray[np.uint8]:
    """:func:`read_color_image` on the bytes of a file (a client's upload, say): the same
    checks, with ``source`` naming it in the messages."""
    return decode_color_images([(data, source)])[0]


def decode_color_images(files: Sequence[tuple[bytes, str | os.PathLike[str]]]
                        ) -> list[NDArray[np.uint8]]:
    """:func:`decode_color_image` on several files at once, decoded in parallel threads (the
    two views of a stereo pair: one PNG decode instead of two in the wall time).

    Parameters
    ----------
    files : sequence of (bytes, source)
        Each file's bytes and the name its messages give.

    Returns
    -------
    list of ndarray
        8-bit BGR (H, W, 3) images in the order of ``files``.
    """
    checked = []
    for data, source in files:
        if len(data) > MAX_IMAGE_FILE_BYTES:
            raise InputError(source, f"image is larger than the {MAX_IMAGE_FILE_BYTES >> 20} "
                                     "MiB photomodel reads")
        checked.append(_checked(source, data, "image"))
    decoded = _decode_many([np.frombuffer(data, dtype=np.uint8) for data, _ in files],
                           cv2.IMREAD_UNCHANGED,
                           parallel=sum(fmt != "BMP" for fmt in checked) > 1)
    return [_colour(source, *_judged(source, fmt, image, messages, stacklevel=4))
            for (_, source), fmt, (image, messages) in zip(files, checked, decoded, strict=True)]


def _colour(source: str | os.PathLike[str], image: NDArray, fmt: str) -> NDArray[np.uint8]:
    """A decoded image as 8-bit BGR, or the error that says why it cannot be one."""
    if image.dtype == np.uint16:
        image = (image // 257).astype(np.uint8)
    elif image.dtype != np.uint8:
        raise InputError(source, f"{fmt} of {image.dtype} samples is not supported (8 or 16 "
                                 "bits)")
    if image.ndim == 2 or image.shape[2] < 3:
        raise InputError(source, "image is greyscale; the photo-model method needs colour "
                                 "(hue)")
    if image.shape[2] == 4:
        image = cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
    return np.ascontiguousarray(image)


def read_grey_image(path: str | os.PathLike[str], kind: str = "image") -> NDArray[np.uint8]:
    """Read an image (PNG, BMP or JPEG) as 8-bit grey levels (H, W): a mask, for one.

    The checks of :func:`read_color_image`; a colour image is converted to grey.
    ``kind`` names the file in messages ("mask": "mask file not found").
    """
    p = Path(path)
    data = read_capped(p, f"{kind} file", MAX_IMAGE_FILE_BYTES)
    image, fmt = _decoded(p, data, cv2.IMREAD_GRAYSCALE, kind)
    if image.dtype != np.uint8 or image.ndim != 2:
        raise InputError(p, f"{fmt} is not readable as 8-bit grey levels")
    return np.ascontiguousarray(image)


def _decoded(source: str | os.PathLike[str], data: bytes, flags: int, kind: str
             ) -> tuple[NDArray, str]:
    """The decoded image and its format, after every check before and after decoding."""
    fmt = _checked(source, data, kind)
    [(image, messages)] = _decode_many([np.frombuffer(data, dtype=np.uint8)], flags)
    return _judged(source, fmt, image, messages, stacklevel=4)


def _checked(source: str | os.PathLike[str], data: bytes, kind: str) -> str:
    """The format of ``data`` after the checks before decoding."""
    if not data:
        raise InputError(source, f"{kind} file is empty")
    return _check_header(source, data)


def _judged(source: str | os.PathLike[str], fmt: str, image: NDArray | None,
            messages: list[str], stacklevel: int) -> tuple[NDArray, str]:
    """The decoder's answer as (image, format), the error if it gave no image, a warning if
    it found damaged data."""
    if image is None:
        detail = f" ({messages[0]})" if messages else ""
        raise InputError(source, f"damaged {fmt} data: not a readable image{detail}")
    damage = [m for m in messages if _DAMAGE.search(m)]
    if damage:
        warnings.warn(InputWarning(source, f"damaged {fmt} data ({damage[0]}); parts of the "
                                           "image may be missing"), stacklevel=stacklevel)
    return image, fmt


def write_image(path: str | os.PathLike[str], image: NDArray[np.uint8]) -> None:
    """Write an image atomically (:func:`~photomodel._files.write_atomic`); format from the
    suffix."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    ok, buf = cv2.imencode(p.suffix or ".png", image)
    if not ok:
        raise InputError(p, f"cannot encode an image as {p.suffix or '.png'}")
    write_atomic(p, buf.tobytes())


# --- headers -------------------------------------------------------------------------------


def _check_header(path: str | os.PathLike[str], data: bytes) -> str:
    """The format ("PNG", "BMP", "JPEG") after its header's checks; InputError when the file
    is none of them, claims more than ``MAX_IMAGE_PIXELS``, is damaged or cut short."""
    head = data[:8]
    if head == _PNG_SIGNATURE:
        _png_check(path, data)
        return "PNG"
    if head[:2] == b"BM":
        _bmp_check(path, data)
        return "BMP"
    if head[:3] == b"\xff\xd8\xff":
        _jpeg_check(path, data)
        return "JPEG"
    raise InputError(path, "not a readable image (not a PNG, BMP or JPEG file)")


def _check_pixels(path: str | os.PathLike[str], fmt: str, width: int, height: int) -> None:
    if width * height > MAX_IMAGE_PIXELS:
        raise InputError(path, f"{fmt} claims {width}x{height} pixels, more than the "
                               f"{MAX_IMAGE_PIXELS / 1e6:.0f} megapixels photomodel reads")
    if max(width, height) > MAX_IMAGE_SIDE_PX:
        raise InputError(path, f"{fmt} claims {width}x{height} pixels; photomodel reads "
                               f"images of at most {MAX_IMAGE_SIDE_PX} pixels a side")


def _png_check(path: str | os.PathLike[str], data: bytes) -> None:
    """Walk the chunks: IHDR first and valid, every chunk whole with its CRC, IDAT, IEND."""
    n, pos, chunks, seen_idat = len(data), 8, 0, False
    view = memoryview(data)
    while True:
        if pos + 8 > n:
            raise InputError(path, "truncated PNG (no IEND chunk: the file is cut short)")
        length, kind = struct.unpack_from(">I4s", data, pos)
        if pos + 12 + length > n:
            name = kind.decode("latin-1")   # a damaged file's chunk type may be any bytes
            raise InputError(path, "truncated PNG (the file ends inside its "
                                   f"{name if name.isalnum() else ascii(name)} chunk)")
        body = view[pos + 8:pos + 8 + length]
        (crc,) = struct.unpack_from(">I", data, pos + 8 + length)
        if zlib.crc32(body, zlib.crc32(kind)) != crc:
            raise InputError(path, f"damaged PNG (chunk {kind.decode('latin-1')!r} fails its "
                                   "CRC check)")
        if chunks == 0:
            if kind != b"IHDR" or length != 13:
                raise InputError(path, "damaged PNG (no IHDR chunk first)")
            width, height, depth, colour, compression, filtering, interlace = struct.unpack(
                ">IIBBBBB", body)
            if not (0 < width < 1 << 31 and 0 < height < 1 << 31) or compression or filtering \
                    or interlace > 1 or depth not in _PNG_BIT_DEPTHS.get(colour, ()):
                raise InputError(path, "damaged PNG (invalid IHDR: size, bit depth, colour "
                                       "type or method)")
            _check_pixels(path, "PNG", width, height)
        seen_idat |= kind == b"IDAT"
        chunks += 1
        pos += 12 + length
        if kind == b"IEND":
            break
        if chunks > _PNG_MAX_CHUNKS:
            raise InputError(path, f"PNG of more than {_PNG_MAX_CHUNKS} chunks")
    if not seen_idat:
        raise InputError(path, "damaged PNG (no image data)")


def _bmp_check(path: str | os.PathLike[str], data: bytes) -> None:
    """BITMAPCOREHEADER (12 bytes) or BITMAPINFOHEADER and its successors (40+ bytes)."""
    n = len(data)
    if n < 26:
        raise InputError(path, "truncated BMP (no complete header)")
    (offset,) = struct.unpack_from("<I", data, 10)
    (size,) = struct.unpack_from("<I", data, 14)
    if size == 12:
        width, height, _, bits = struct.unpack_from("<HHHH", data, 18)
        compression = 0
    elif 40 <= size <= 124 and n >= 34:
        width, height, _, bits, compression = struct.unpack_from("<iiHHI", data, 18)
        height = abs(height)
    else:
        raise InputError(path, "damaged BMP (unknown or truncated info header)")
    if width <= 0 or height <= 0 or bits not in (1, 4, 8, 16, 24, 32):
        raise InputError(path, f"damaged BMP (size {width}x{height}, {bits} bits per pixel)")
    _check_pixels(path, "BMP", width, height)
    if compression in (0, 3):  # uncompressed rows: their size is known
        row = (width * bits + 31) // 32 * 4
        if offset + row * height > n:
            raise InputError(path, "truncated BMP (the file ends before its last pixel row)")


def _jpeg_check(path: str | os.PathLike[str], data: bytes) -> None:
    """The frame header (SOFn) after the segments before it."""
    n, pos = len(data), 2
    for _ in range(_JPEG_MAX_SEGMENTS):
        found = _JPEG_MARKER.search(data, pos)  # stray bytes are skipped, as libjpeg does
        if found is None or found.end() + 2 > n:
            break
        marker, pos = data[found.end() - 1], found.end()
        if marker == 0x01 or 0xD0 <= marker <= 0xD8:    # TEM, RSTn, SOI: no length
            continue
        if marker in (0xD9, 0xDA):
            raise InputError(path, "damaged JPEG (no frame header before the image data)")
        (length,) = struct.unpack_from(">H", data, pos)
        if marker in _JPEG_SOF:
            if length < 8 or pos + 7 > n:
                break
            height, width = struct.unpack_from(">HH", data, pos + 3)
            if width == 0 or height == 0:
                raise InputError(path, f"JPEG of size {width}x{height} is not supported")
            _check_pixels(path, "JPEG", width, height)
            if data.count(b"\xff\xda") > _JPEG_MAX_SCANS:
                raise InputError(path, f"JPEG of more than {_JPEG_MAX_SCANS} scans")
            return
        if length < 2:
            raise InputError(path, "damaged JPEG (a segment of invalid length)")
        pos += length
    raise InputError(path, "damaged or truncated JPEG (no frame header)")


# --- decoding ------------------------------------------------------------------------------


def _decode_many(arrays: Sequence[NDArray[np.uint8]], flags: int, parallel: bool = False
                 ) -> list[tuple[NDArray | None, list[str]]]:
    """``cv2.imdecode`` of each array with OpenCV's log off and the decoders' own stderr
    messages caught: [(image or None, its messages)]. With ``parallel`` (compressed files:
    a thread costs more than copying a BMP) the arrays are decoded in parallel threads inside
    one catching window; if the decoders said anything there, the arrays are decoded again
    one by one, so that each message is told to the file it is about."""
    with _DECODE_LOCK:
        level = cv2.utils.logging.getLogLevel()
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
        try:
            with _stderr_caught() as caught:
                if len(arrays) == 1 or not parallel:
                    images = [_imdecode(a, flags) for a in arrays]
                else:
                    rest = [_decoder().submit(_imdecode, a, flags) for a in arrays[1:]]
                    images = [_imdecode(arrays[0], flags)] + [f.result() for f in rest]
            said = [m for m in caught if m]
            if len(arrays) == 1:
                return [(images[0], said)]
            if not said:
                return [(image, []) for image in images]
            answers = []
            for a in arrays:
                with _stderr_caught() as one:
                    image = _imdecode(a, flags)
                answers.append((image, [m for m in one if m]))
            return answers
        finally:
            cv2.utils.logging.setLogLevel(level)


def _decoder() -> ThreadPoolExecutor:
    """The one thread that decodes the second of several files (held: ``_DECODE_LOCK``):
    made once, so that no thread and no malloc arena is made per decode."""
    global _DECODER
    if _DECODER is None:
        _DECODER = ThreadPoolExecutor(1, thread_name_prefix="photomodel-decode")
    return _DECODER


def _imdecode(data: NDArray[np.uint8], flags: int) -> NDArray | None:
    """``cv2.imdecode``, None where OpenCV raises."""
    try:
        return cv2.imdecode(data, flags)
    except (cv2.error, SystemError):  # OpenCV 5 may wrap cv2.error
        return None


@contextlib.contextmanager
def _stderr_caught() -> Iterator[list[str]]:
    """Point file descriptor 2 at a temporary file while the body runs; yield a list that
    then holds the decoders' lines (libpng, libjpeg, OpenCV). Other lines written meanwhile
    (another thread's) go on to the real stderr afterwards."""
    caught: list[str] = []
    try:
        tmp = tempfile.TemporaryFile()
    except OSError:  # no temporary file to be had: decode without catching
        yield caught
        return
    with tmp:
        try:
            saved = os.dup(2)
        except OSError:  # no stderr at all: nothing to protect
            yield caught
            return
        try:
            with contextlib.suppress(Exception):
                sys.stderr.flush()
            os.dup2(tmp.fileno(), 2)
            try:
                yield caught
            finally:
                os.dup2(saved, 2)
        finally:
            os.close(saved)
        tmp.seek(0)
        text = tmp.read(1 << 20).decode("utf-8", "replace")
    others = []
    for line in text.splitlines():
        if _DECODER_LINE.match(line):
            caught.append(line.removeprefix("libpng error: ").removeprefix("libpng warning: "))
        elif line.strip():
            others.append(line)
    if others:
        with contextlib.suppress(OSError):
            os.write(2, ("\n".join(others) + "\n").encode())
