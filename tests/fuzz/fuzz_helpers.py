"""Shared by the loaders' fuzz tests: seed files, mutation strategies, a bounded call that
counts what came back, and hand-made zip archives (bombs) for the memory tests."""

from __future__ import annotations

import io
import json
import re
import resource
import struct
import warnings
import zlib
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

from photomodel.errors import InputError, InputWarning

# --- profiles ------------------------------------------------------------------------------

SHORT_EXAMPLES = {"calibration": 2000, "image": 2000, "model": 500}
"""Examples per test in the normal suite: about a minute over all fuzz tests on 2 cores."""
LONG_FACTOR = 20
"""The ``slow`` runs try this many times as many."""


def fuzz_settings(kind: str, long: bool = False) -> settings:
    n = SHORT_EXAMPLES[kind] * (LONG_FACTOR if long else 1)
    return settings(max_examples=n, deadline=None, print_blob=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                           HealthCheck.filter_too_much])


# --- counting and bounding -----------------------------------------------------------------

MEMORY_MARGIN = 1 << 30
"""Address space a single load may add (RLIMIT_AS is set to the process's size plus this):
a load that tries to allocate more fails with MemoryError, which the fuzz tests count as a
crash. The largest input a loader accepts needs about 600 MB (a 285 MB model)."""


@dataclass
class Tally:
    """What the loader of one fuzz test did with its inputs."""

    tried: int = 0
    accepted: int = 0
    input_errors: int = 0
    warnings: int = 0
    other_exceptions: int = 0
    examples_of_other: list[str] = field(default_factory=list)
    problems: Counter[str] = field(default_factory=Counter)

    def as_dict(self) -> dict[str, Any]:
        return {"tried": self.tried, "accepted": self.accepted,
                "input_errors": self.input_errors, "warnings": self.warnings,
                "other_exceptions": self.other_exceptions,
                "examples_of_other": self.examples_of_other[:5],
                "most_common_problems": self.problems.most_common(8)}


def _address_space_bytes() -> int | None:
    try:
        text = Path("/proc/self/status").read_text()
    except OSError:
        return None
    found = re.search(r"^VmSize:\s+(\d+) kB", text, re.MULTILINE)
    return int(found.group(1)) * 1024 if found else None


def bounded_call(tally: Tally, load: Callable[[Path], Any], path: Path) -> Any | None:
    """``load(path)`` with the address space bounded; count the outcome. Returns the loaded
    object, or None for an InputError; any other exception (MemoryError included) is
    counted and re-raised, as is a warning that is not an InputWarning."""
    tally.tried += 1
    size = _address_space_bytes()
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            if size is not None:
                resource.setrlimit(resource.RLIMIT_AS, (size + MEMORY_MARGIN, hard))
            try:
                result = load(path)
            finally:
                resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
    except InputError as exc:
        tally.input_errors += 1
        assert "\n" not in str(exc), str(exc)
        assert exc.source == str(path), str(exc)
        tally.problems[_shape(exc.problem)] += 1
        return None
    except BaseException as exc:
        tally.other_exceptions += 1
        tally.examples_of_other.append(f"{type(exc).__name__}: {str(exc)[:200]}")
        raise
    others = [w for w in caught if not issubclass(w.category, InputWarning)]
    if others:
        tally.other_exceptions += 1
        tally.examples_of_other.append(f"warning {others[0].category.__name__}: "
                                       f"{others[0].message}")
        raise AssertionError(f"a warning that is not an InputWarning: {others[0].message}")
    tally.warnings += len(caught)
    tally.accepted += 1
    return result


def _shape(problem: str) -> str:
    """A problem without its numbers (to count the kinds of refusal)."""
    return re.sub(r"[-+]?\d[\d.e+-]*", "#", problem)[:70]


def write_counts(path: Path, profile: str, tallies: dict[str, Tally], command: str) -> None:
    """Merge the tallies of one run into ``path`` (JSON), each loader's with the command
    that produced it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        data = {}
    loaders = data.setdefault(profile, {}).setdefault("loaders", {})
    loaders.update({k: {**t.as_dict(), "command": command} for k, t in tallies.items()
                    if t.tried})
    data[profile].pop("command", None)
    data[profile]["total_tried"] = sum(t["tried"] for t in loaders.values())
    data[profile]["total_other_exceptions"] = sum(t["other_exceptions"]
                                                  for t in loaders.values())
    path.write_text(json.dumps(data, indent=2) + "\n")


# --- byte mutations ------------------------------------------------------------------------

_INTERESTING_BYTES = (0x00, 0x01, 0x7F, 0x80, 0xFF, 0xFE)
_INTERESTING_WORDS = (0, 1, 0x7FFF, 0x8000, 0xFFFF, 0xEA60, 0x7FFFFFFF, 0x80000000,
                      0xFFFFFFFF, 60000, 30000)


@st.composite
def mutated_bytes(draw: st.DrawFn, seed: bytes, header: int = 64, keep: int = 0,
                  text: bool = False) -> bytes:
    """``seed`` with 1-4 byte-level mutations: bit flips, set bytes, 16/32-bit fields set to
    boundary values (half of them in the first ``header`` bytes), insertions, deletions,
    truncation, extension, a repeated slice. Three times in four the first ``keep`` bytes (a
    format's signature) are left alone; with ``text`` the inserted bytes are printable."""
    data = bytearray(seed)
    start = draw(st.sampled_from((keep, keep, keep, 0)))  # hypothesis favours the first
    binary = st.text(st.characters(min_codepoint=9, max_codepoint=126), min_size=1,
                     max_size=32).map(str.encode) if text else st.binary(min_size=1,
                                                                         max_size=32)
    for _ in range(draw(st.integers(1, 4))):
        n = len(data)
        op = draw(st.sampled_from(("flip", "byte", "word", "insert", "delete", "truncate",
                                   "extend", "repeat")))
        in_header = draw(st.booleans())
        limit = max(start + 1, min(n, header) if in_header else n)
        pos = min(draw(st.integers(start, limit - 1)), max(n - 1, 0)) if n else 0
        if op == "flip" and n:
            data[pos] ^= 1 << draw(st.integers(0, 7))
        elif op == "byte" and n:
            data[pos] = draw(st.sampled_from(_INTERESTING_BYTES) | st.integers(0, 255))
        elif op == "word" and n >= 4:
            pos = min(pos, n - 4)
            fmt = draw(st.sampled_from((">I", "<I", ">H", "<H", "<i")))
            value = draw(st.sampled_from(_INTERESTING_WORDS))
            size = struct.calcsize(fmt)
            if fmt == "<i":
                value = draw(st.sampled_from((-1, -60000, -(1 << 31))))
            data[pos:pos + size] = struct.pack(fmt, value & ((1 << (8 * size)) - 1)
                                               if fmt != "<i" else value)
        elif op == "insert":
            data[pos:pos] = draw(binary)
        elif op == "delete" and n:
            del data[pos:pos + draw(st.integers(1, 64))]
        elif op == "truncate" and n:
            del data[draw(st.integers(min(start, n - 1), n - 1)):]
        elif op == "extend":
            data += draw(binary)
        elif op == "repeat" and n:
            end = min(n, pos + draw(st.integers(1, 256)))
            data[end:end] = data[pos:end] * draw(st.integers(1, 8))
    return bytes(data)


def fix_png_crcs(data: bytes) -> bytes:
    """The PNG with every whole chunk's CRC recomputed (so that a mutated header reaches the
    decoder instead of failing the CRC check); the bytes unchanged when not a PNG."""
    if not data.startswith(b"\x89PNG\r\n\x1a\n"):
        return data
    out, pos = bytearray(data[:8]), 8
    while pos + 12 <= len(data):
        (length,) = struct.unpack_from(">I", data, pos)
        end = pos + 12 + length
        if end > len(data):
            break
        body = data[pos + 4:pos + 8 + length]
        out += data[pos:pos + 8 + length] + struct.pack(">I", zlib.crc32(body))
        pos = end
    return bytes(out + data[pos:])


def png_with_ihdr(width: int, height: int, depth: int = 8, colour: int = 2,
                  idat: bytes | None = None) -> bytes:
    """A PNG whose header claims ``width`` x ``height`` (and a tiny or given IDAT)."""

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(
            ">I", zlib.crc32(kind + body))

    ihdr = struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr)
            + chunk(b"IDAT", zlib.compress(b"\x00" * 16) if idat is None else idat)
            + chunk(b"IEND", b""))


def bmp_with_header(width: int, height: int, bits: int = 24, pixels: bytes = b"\x00" * 10
                    ) -> bytes:
    """A BMP (BITMAPINFOHEADER) whose header claims ``width`` x ``height``."""
    info = struct.pack("<IiiHHIIiiII", 40, width, height, 1, bits, 0, 0, 2835, 2835, 0, 0)
    return b"BM" + struct.pack("<IHHI", 54 + len(pixels), 0, 0, 54) + info + pixels


def jpeg_with_sof(width: int, height: int) -> bytes:
    """A minimal JPEG start whose frame header claims ``width`` x ``height``."""
    sof = struct.pack(">HBHHB", 11, 8, height, width, 1) + b"\x01\x11\x00"
    return b"\xff\xd8" + b"\xff\xc0" + sof + b"\xff\xd9"


def seed_images(rng: int = 0) -> dict[str, bytes]:
    """Small valid colour images in each format (and a 16-bit and an RGBA PNG)."""
    generator = np.random.default_rng(rng)
    image = cv2.GaussianBlur(generator.integers(0, 256, (24, 32, 3), dtype=np.uint8), (0, 0), 2)
    out = {f"img.{ext}": cv2.imencode(f".{ext}", image)[1].tobytes()
           for ext in ("png", "bmp", "jpg")}
    out["img16.png"] = cv2.imencode(".png", image.astype(np.uint16) * 257)[1].tobytes()
    out["rgba.png"] = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_BGR2BGRA))[1].tobytes()
    out["progressive.jpg"] = cv2.imencode(".jpg", image,
                                          [cv2.IMWRITE_JPEG_PROGRESSIVE, 1])[1].tobytes()
    return out


# --- calibration texts ---------------------------------------------------------------------

ROS_CAMERA_INFO = """\
image_width: 640
image_height: 480
camera_name: hand_right
camera_matrix:
  rows: 3
  cols: 3
  data: [801.2, 0, 322.1, 0, 800.6, 238.4, 0, 0, 1]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [-0.15, 0.06, 0.0011, -0.0008, 0]
"""

CAMERA_INFO_MESSAGE = """\
header:
  seq: 0
  frame_id: cam1
height: 480
width: 640
distortion_model: plumb_bob
D: [-0.15, 0.06, 0.0011, -0.0008, 0.0]
K: [801.2, 0.0, 322.1, 0.0, 800.6, 238.4, 0.0, 0.0, 1.0]
R: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
P: [801.2, 0.0, 322.1, 0.0, 0.0, 800.6, 238.4, 0.0, 0.0, 0.0, 1.0, 0.0]
binning_x: 0
---
"""

PLAIN_STEREO = """\
%YAML:1.0
---
image_width: 640
image_height: 480
K1: [[801.2, 0, 322.1], [0, 800.6, 238.4], [0, 0, 1]]
D1: [-0.15, 0.06, 0.0011, -0.0008, 0]
K2: [798.4, 0, 317.6, 0, 798.9, 241.3, 0, 0, 1]
D2: [-0.145, 0.058, -0.0009, 0.0012, 0]
R: [0.0131, -0.1738, 0.0041]
T: [[119.5], [0], [10.4]]
"""

_NUMBER = re.compile(rb"-?\d+\.?\d*(?:[eE][-+]?\d+)?")
_REPLACEMENTS = (b"1e12", b"-640", b".inf", b"-.inf", b".nan", b"abc", b"\"text\"", b"[1, 2]",
                 b"[[1], [2], [3]]", b"{a: 1}", b"0", b"-0", b"1e-300", b"1e308", b"1e999",
                 b"99999999999999999999", b"null", b"~", b"[]", b"{}", b"true", b"0x10",
                 b"NaN", b"Infinity", b"[[[1]]]", b"3.5", b"65536", b"-1")
_KEYS = (b"K1", b"K2", b"M1", b"D1", b"D2", b"R", b"T", b"image_width", b"image_height",
         b"camera_matrix", b"distortion_coefficients", b"K", b"D", b"width", b"height",
         b"distance_mm", b"rows", b"cols", b"data", b"dt", b"type_id")


@st.composite
def mutated_calibration(draw: st.DrawFn, seed: bytes) -> bytes:
    """``seed`` with 1-3 token-level mutations (a number replaced by a boundary value, a
    string, a list or a mapping; a key renamed, a line deleted or repeated), then perhaps
    byte-level ones."""
    data = seed
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(("number", "number", "key", "drop_line", "repeat_line")))
        if op == "number":
            spans = [m.span() for m in _NUMBER.finditer(data)]
            if spans:
                a, b = draw(st.sampled_from(spans))
                data = data[:a] + draw(st.sampled_from(_REPLACEMENTS)) + data[b:]
        elif op == "key":
            present = [k for k in _KEYS if re.search(rb"\b" + k + rb"\b", data)]
            if present:
                old = draw(st.sampled_from(present))
                data = re.sub(rb"\b" + old + rb"\b", draw(st.sampled_from(_KEYS)), data,
                              count=1)
        else:
            lines = data.split(b"\n")
            i = draw(st.integers(0, len(lines) - 1))
            if op == "drop_line":
                del lines[i]
            else:
                lines.insert(i, lines[i])
            data = b"\n".join(lines)
    if draw(st.integers(0, 3)) == 3:
        data = draw(mutated_bytes(data, header=len(data), text=draw(st.integers(0, 3)) < 3))
    return data


# --- model archives ------------------------------------------------------------------------

_JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-(1 << 70), 1 << 70)
    | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=4), inner,
                                                                  max_size=3),
    max_leaves=10)
_META_KEYS = ("version", "format", "name", "camera_K", "camera_dist", "distance_mm",
              "centroid_in_camera_mm", "photo_size_px")
_DTYPES = ("u1", "i8", "f8", "f4", "?", "U5", "c16", "i2", ">f8")


def read_archive(data: bytes) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    with np.load(io.BytesIO(data), allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files if k != "meta"}
        meta = json.loads(str(z["meta"]))
    return arrays, meta


@st.composite
def mutated_model(draw: st.DrawFn, arrays: dict[str, np.ndarray], meta: dict[str, Any]
                  ) -> bytes:
    """A model archive with 1-3 changes to its metadata (a key set to any JSON value or
    removed) or its arrays (another dtype or shape, scaled, a NaN, fewer rows, transposed,
    removed, an extra member, an object array, Fortran order), packed by numpy, then perhaps
    byte-level mutations."""
    arrays = dict(arrays)
    meta = dict(meta)
    for _ in range(draw(st.integers(1, 3))):
        if draw(st.booleans()):
            key = draw(st.sampled_from(_META_KEYS))
            if draw(st.integers(0, 4)) == 4:
                meta.pop(key, None)
            else:
                meta[key] = draw(_JSON_VALUES)
            continue
        key = draw(st.sampled_from(sorted(arrays) + ["extra"]))
        op = draw(st.sampled_from(("dtype", "shape", "scale", "nan", "rows", "transpose",
                                   "remove", "object", "random", "fortran")))
        a = arrays.get(key, np.zeros(3))
        if op == "dtype":
            dtype = draw(st.sampled_from(_DTYPES))
            try:
                with warnings.catch_warnings():  # complex to real, say: not the loader's
                    warnings.simplefilter("ignore")
                    arrays[key] = a.astype(dtype)
            except (ValueError, TypeError, OverflowError):
                arrays[key] = np.zeros(a.shape, dtype=dtype)
        elif op == "shape":
            shape = tuple(draw(st.lists(st.integers(0, 5), max_size=4)))
            arrays[key] = np.zeros(shape, dtype=a.dtype if a.dtype.kind != "U" else "f8")
        elif op == "scale" and a.dtype.kind in "fiu":
            factor = draw(st.sampled_from((1e6, -1.0, 0.0, 1e-6, 2.0)))
            with np.errstate(all="ignore"):
                arrays[key] = (a * factor).astype(a.dtype)
        elif op == "nan" and a.dtype.kind == "f" and a.size:
            b = a.copy()
            with np.errstate(all="ignore"):  # 1e300 into float32 is inf
                b.flat[draw(st.integers(0, a.size - 1))] = draw(st.sampled_from(
                    (np.nan, np.inf, -np.inf, 1e300)))
            arrays[key] = b
        elif op == "rows" and a.ndim:
            arrays[key] = a[:draw(st.integers(0, min(len(a), 4)))]
        elif op == "transpose":
            arrays[key] = a.T.copy()
        elif op == "fortran":
            arrays[key] = np.asfortranarray(a)
        elif op == "remove":
            arrays.pop(key, None)
        elif op == "object":
            arrays[key] = np.array([1, "a", None], dtype=object)
        elif op == "random":
            arrays[key] = np.frombuffer(draw(st.binary(min_size=8, max_size=64)),
                                        dtype=np.uint8)
    buf = io.BytesIO()
    save = np.savez_compressed if draw(st.booleans()) else np.savez
    payload = {k: v for k, v in arrays.items()}
    try:
        save(buf, meta=np.array(json.dumps(meta)), **payload)
    except ValueError:  # numpy refuses to write an object array without pickle: skip it
        payload = {k: v for k, v in payload.items() if v.dtype != object}
        buf = io.BytesIO()
        save(buf, meta=np.array(json.dumps(meta)), **payload)
    data = buf.getvalue()
    if draw(st.integers(0, 3)) == 3:
        data = draw(mutated_bytes(data, header=256))
    return data


# --- hand-made zip archives ----------------------------------------------------------------


def deflate_zeros(n_bytes: int, chunk: int = 1 << 24) -> bytes:
    """A raw deflate stream of ``n_bytes`` zero bytes, built in well under a second for any
    size: after a full flush the compressor's output for another chunk of zeros is always
    the same bytes, so it is repeated."""
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    zeros = bytes(chunk)
    first = c.compress(zeros) + c.flush(zlib.Z_FULL_FLUSH)
    repeat = c.compress(zeros) + c.flush(zlib.Z_FULL_FLUSH)
    full, rest = divmod(n_bytes, chunk)
    if full == 0:
        c = zlib.compressobj(9, zlib.DEFLATED, -15)
        return c.compress(bytes(rest)) + c.flush()
    tail = zlib.compressobj(9, zlib.DEFLATED, -15)
    return first + repeat * (full - 1) + tail.compress(bytes(rest)) + tail.flush()


@dataclass(frozen=True)
class Member:
    """One zip member as written: its name, its bytes as stored, how, and what the
    directory declares."""

    name: str
    stored: bytes
    method: int
    crc: int
    file_size: int


def member(name: str, data: bytes, deflate: bool = True) -> Member:
    if deflate:
        c = zlib.compressobj(6, zlib.DEFLATED, -15)
        stored = c.compress(data) + c.flush()
    else:
        stored = data
    return Member(name, stored, 8 if deflate else 0, zlib.crc32(data), len(data))


def write_zip(members: list[Member]) -> bytes:
    """A ZIP64 archive of ``members`` (each header declares the member's ``file_size``,
    whatever its stored bytes unpack to)."""
    out, directory = bytearray(), bytearray()
    for m in members:
        name = m.name.encode()
        extra = struct.pack("<HHQQ", 1, 16, m.file_size, len(m.stored))
        offset = len(out)
        out += struct.pack("<4s5H3L2H", b"PK\x03\x04", 45, 0, m.method, 0, 0, m.crc,
                           0xFFFFFFFF, 0xFFFFFFFF, len(name), len(extra)) + name + extra
        out += m.stored
        extra_cd = struct.pack("<HHQQQ", 1, 24, m.file_size, len(m.stored), offset)
        directory += struct.pack("<4s6H3L5H2L", b"PK\x01\x02", 45, 45, 0, m.method, 0, 0,
                                 m.crc, 0xFFFFFFFF, 0xFFFFFFFF, len(name), len(extra_cd), 0,
                                 0, 0, 0, 0xFFFFFFFF) + name + extra_cd
    cd_offset = len(out)
    out += directory
    eocd64_offset = len(out)
    out += struct.pack("<4sQ2H2L4Q", b"PK\x06\x06", 44, 45, 45, 0, 0, len(members),
                       len(members), len(directory), cd_offset)
    out += struct.pack("<4sLQL", b"PK\x06\x07", 0, eocd64_offset, 1)
    out += struct.pack("<4s4H2LH", b"PK\x05\x06", 0, 0, 0xFFFF, 0xFFFF, 0xFFFFFFFF,
                       0xFFFFFFFF, 0)
    return bytes(out)


def npy_bytes(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, array, allow_pickle=False)
    return buf.getvalue()


def npy_header(shape: tuple[int, ...], dtype: str = "|u1") -> bytes:
    """A ``.npy`` header (version 1.0) declaring ``shape`` and ``dtype``, without data."""
    text = f"{{'descr': '{dtype}', 'fortran_order': False, 'shape': {shape!r}, }}"
    text += " " * (-(len(text) + 11) % 64) + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(text)) + text.encode("latin-1")


def model_members(arrays: dict[str, np.ndarray], meta: dict[str, Any],
                  skip: tuple[str, ...] = ()) -> list[Member]:
    """The members of a valid model archive (minus ``skip``), in numpy's names."""
    members = [member("meta.npy", npy_bytes(np.array(json.dumps(meta))))]
    members += [member(f"{k}.npy", npy_bytes(v)) for k, v in arrays.items() if k not in skip]
    return members


def bomb_archive(arrays: dict[str, np.ndarray], meta: dict[str, Any], n_bytes: int,
                 honest_crc: bool = False) -> bytes:
    """A valid model whose ``photo_bgr`` member unpacks to ``n_bytes`` (an npy header for
    that many bytes, then zeros): about n / 1030 bytes on disk."""
    header = npy_header((n_bytes,))
    zeros = deflate_zeros(n_bytes)
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    # header, then the zero stream: a stored-then-deflated prefix is not possible in one
    # raw stream, so the header is compressed with a full flush and the zeros follow.
    prefix = c.compress(header) + c.flush(zlib.Z_FULL_FLUSH)
    crc = zlib.crc32(header)
    crc = _crc_of_zeros_after(crc, n_bytes) if honest_crc else crc
    photo = Member("photo_bgr.npy", prefix + zeros, 8, crc, len(header) + n_bytes)
    return write_zip([*model_members(arrays, meta, skip=("photo_bgr",)), photo])


def _crc_of_zeros_after(crc: int, n_bytes: int, chunk: int = 1 << 24) -> int:
    zeros = bytes(chunk)
    full, rest = divmod(n_bytes, chunk)
    for _ in range(full):
        crc = zlib.crc32(zeros, crc)
    return zlib.crc32(bytes(rest), crc)
