"""Run every bad-input case of ``docs/bad-inputs.md`` and write that table (issue 40).

Builds a small valid setup in a temporary directory with the CLI itself (``photomodel
simulate``, ``build``, ``models add``), writes one bad file (or picks one bad option) per case,
runs ``photomodel`` on it as a real process and records what the user sees: the exit code and
stderr. The table is regenerated from the code, so it stays true::

    python scripts/bad_inputs.py --out docs/bad-inputs.md     # write the table
    python scripts/bad_inputs.py --check docs/bad-inputs.md   # exit 1 with a diff if it changed
    python scripts/bad_inputs.py --only image                 # some cases, table on stdout

The script exits 1 when a case prints a traceback, exits with another code than the one the
case expects (0 where an error is expected, say) or leaves behind what it must not (a
replaced file, a half-written output).
"""

from __future__ import annotations

import argparse
import contextlib
import difflib
import io
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import zipfile
import zlib
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

__all__ = ["Case", "Outcome", "cases", "main", "render", "run_cases"]

GENERATE = "python scripts/bad_inputs.py --out docs/bad-inputs.md"
TIMEOUT_S = 300.0
MAX_LINE_CHARS = 300

GROUPS = ("Images", "Calibrations", "Calibrating", "Model files", "Model library", "Registering",
          "Tracking", "Camera sources", "Security", "Options")

# The valid files every case starts from (written by `setup`); a case replaces one of them.
VALID = {
    "locate": (("--model", "shirt.npz"), ("--stereo", "stereo.yaml"),
               ("--right", "right.png"), ("--left", "left.png")),
    "build": (("--photo", "photo.bmp"), ("--background", "background.bmp"),
              ("--camera", "camera.yaml"), ("--out", "out/{slug}.npz")),
    "track": (("--model", "shirt.npz"), ("--stereo", "stereo.yaml"), ("--frames", "frames")),
    "serve": (("--stereo", "stereo.yaml"), ("--models", "lib")),
}
TRACK_FRAMES = ("000000", "000001", "000002")
"""The valid sequence ``frames/``: three frames, each the scene's pair."""


# --- cases ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Case:
    """One bad input: how to make it, how to run the CLI on it, what must come of it.

    Attributes
    ----------
    group : str
        Kind of input (one table each), one of :data:`GROUPS`.
    name : str
        What is wrong, in words.
    argv : tuple of str
        Arguments of ``photomodel``, paths relative to the work directory.
    short : str
        The command as the table shows it (``locate …`` for the valid files).
    expected_code : int
        The exit code the CLI must give (2: an input error; 0: read, perhaps with a warning;
        1: ``track`` went on past frames it could not read).
    prepare : callable or None
        Writes the case's bad files into the work directory (given as its argument).
    verify : callable or None
        After the run: a problem (str) with what is left in the work directory, or None.
    summary : callable or None
        Stable facts of stdout for a case that exits 0 or 1 (stdout is otherwise not
        shown).
    """

    group: str
    name: str
    argv: tuple[str, ...]
    short: str
    expected_code: int = 2
    prepare: Callable[[Path], None] | None = None
    verify: Callable[[Path], str | None] | None = None
    summary: Callable[[str], str] | None = None


@dataclass(frozen=True)
class Outcome:
    """What one case's run gave: the exit code, stderr with the work directory replaced by
    ``DIR``, the stdout summary and the problems found (empty when the case passed)."""

    case: Case
    code: int | None
    stderr: str
    stdout_summary: str
    problems: tuple[str, ...]
    seconds: float


def _command(cmd: str, slug: str, *options: str) -> tuple[tuple[str, ...], str]:
    """``photomodel CMD`` with the valid files, the given options replacing or adding to them;
    and its short form (``CMD …`` then the given options)."""
    argv: list[str] = [cmd]
    for option, value in VALID.get(cmd, ()):
        if option not in options:
            argv += [option, value.format(slug=slug)]
    argv += options
    short = " ".join([cmd, "…", *(_shell_word(o) for o in options)]) if cmd in VALID else \
        " ".join([cmd, *(_shell_word(o) for o in options)])
    return tuple(argv), short


def _shell_word(word: str) -> str:
    """``word`` as a POSIX shell would need it (``$'...'`` for control characters)."""
    if word and re.fullmatch(r"[\w@%+=:,./-]+", word):
        return word
    if word.isprintable():
        return "'" + word.replace("'", "'\"'\"'") + "'"
    return "$'" + "".join(c if c.isprintable() and c not in "'\\" else
                          ("\\n" if c == "\n" else f"\\u{ord(c):04x}" if ord(c) > 0xFF
                           else f"\\x{ord(c):02x}") for c in word) + "'"


def _case(group: str, name: str, cmd: str, *options: str, **kwargs: Any) -> Case:
    """A :class:`Case` of ``photomodel CMD`` with ``options`` (see :func:`_command`)."""
    slug = re.sub(r"[^a-z0-9]+", "-", f"{group} {name}".lower()).strip("-")
    argv, short = _command(cmd, slug, *options)
    return Case(group, name, argv, short, **kwargs)


def _writes(name: str, make: Callable[[Path], bytes]) -> Callable[[Path], None]:
    """A ``prepare`` that writes ``make(work)`` to ``work/name``."""

    def prepare(work: Path) -> None:
        path = work / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(make(work))

    return prepare


def _rolled(work: Path) -> None:
    """``rolled_r.png`` and ``rolled_l.png``: the scene's views rolled sideways so that the
    garment's middle (camera 1's pixels unlike the border's colour) lies on the image border."""
    right = cv2.imread(str(work / "right.png"))
    band = np.concatenate([right[:8].reshape(-1, 3), right[-8:].reshape(-1, 3)])
    far = np.abs(right.astype(np.int32) - np.median(band, axis=0)).sum(axis=2) > 60
    shift = -int(np.nonzero(far)[1].mean()) if far.any() else right.shape[1] // 2
    for side, name in (("right", "rolled_r.png"), ("left", "rolled_l.png")):
        (work / name).write_bytes(_image_of(work, f"{side}.png", lambda im: np.roll(
            im, shift, axis=1)))


def _register_cases() -> list[Case]:
    """``build`` in place and of unknown scale (the scene's pair as the garment where it
    lies): views of different sizes, an "empty" pair with the garment in it, a garment cut by
    the image border, a photo of unknown scale with nothing on it, a mix of modes."""
    def run(name: str, *options: str, prepare: Callable[[Path], None] | None = None) -> Case:
        slug = re.sub(r"[^a-z0-9]+", "-", name.lower()).strip("-")
        out = f"out/reg-{slug}.model"
        argv = ("build", *options, "--out", out)
        return Case("Registering", name, argv, " ".join(["build", *map(_shell_word, options)]),
                    prepare=prepare, verify=_absent(out, out.replace(".model", ".preview.png")))

    pair = ("--stereo", "stereo.yaml", "--right", "right.png")
    return [
        run("views of different sizes (left 320 x 240)", *pair, "--left", "small.png",
            prepare=_writes("small.png", lambda w: _image_of(
                w, "left.png", lambda im: cv2.resize(im, (320, 240))))),
        run("an empty pair with the garment in it", *pair, "--left", "left.png",
            "--empty-right", "right.png", "--empty-left", "left.png"),
        run("one empty view without the other", *pair, "--left", "left.png", "--empty-right",
            "right.png"),
        run("a garment cut by the image border (the views rolled to put it there)",
            "--stereo", "stereo.yaml", "--right", "rolled_r.png", "--left", "rolled_l.png",
            prepare=_rolled),
        run("a photo of unknown scale with nothing on it", "--scale", "unknown", "--photo",
            "plain.png", prepare=_writes("plain.png", lambda w: _image_of(
                w, "right.png", lambda im: np.full_like(im, 128)))),
        run("in place and a station photo at once", *pair, "--left", "left.png", "--photo",
            "photo.bmp"),
        run("unknown scale with a camera calibration", "--scale", "unknown", "--photo",
            "photo.bmp", "--camera", "camera.yaml"),
    ]


def _security_cases() -> list[Case]:
    """``serve`` refused at start for its token file or TLS files (nothing loaded)."""
    def two_pkis(work: Path) -> None:
        from photomodel.service import make_certs

        for name in ("pki_a", "pki_b"):
            make_certs(work / name, ["cell7"])

    return [
        _case("Security", "a token file with an unknown role", "serve", "--token-file",
              "tokens_role.txt", prepare=_writes("tokens_role.txt", lambda w: b"admin a-token-"
                                                 b"of-20-chars-x alice\noperator b-token-of-20-"
                                                 b"chars-y bob\n")),
        _case("Security", "a token of 8 characters", "serve", "--token-file",
              "tokens_short.txt", prepare=_writes("tokens_short.txt",
                                                  lambda w: b"controller 12345678\n")),
        _case("Security", "one token on two lines", "serve", "--token-file", "tokens_twice.txt",
              prepare=_writes("tokens_twice.txt", lambda w: b"admin same-token-0123456789\n"
                                                            b"controller same-token-0123456789"
                                                            b"\n")),
        _case("Security", "`--tls-cert` without `--tls-key`", "serve", "--tls-cert",
              "alone.pem", prepare=_writes("alone.pem", lambda w: b"not a certificate\n")),
        _case("Security", "a certificate that is not PEM", "serve", "--tls-cert", "junk.pem",
              "--tls-key", "junk.key", prepare=lambda w: [
                  (w / n).write_bytes(b"junk\n") for n in ("junk.pem", "junk.key")] and None),
        _case("Security", "a key that is not the certificate's", "serve", "--tls-cert",
              "pki_a/server.pem", "--tls-key", "pki_b/server.key", prepare=two_pkis),
    ]


def _absent(*names: str) -> Callable[[Path], str | None]:
    """A ``verify``: none of ``names`` exists after the run (nothing half-written)."""

    def verify(work: Path) -> str | None:
        left = [n for n in names if (work / n).exists()]
        return f"left behind {', '.join(left)}" if left else None

    return verify


def _no_model_in(library: str) -> Callable[[Path], str | None]:
    def verify(work: Path) -> str | None:
        found = sorted(p.name for p in (work / library).glob("*.npz"))
        return f"{library} holds {found}" if found else None

    return verify


def _json_found(stdout: str) -> str:
    result = json.loads(stdout)
    return f"stdout: the JSON result, found {str(result['found']).lower()}"


def _model_count(stdout: str) -> str:
    counts = re.findall(r"\d+ model\(s\)", stdout)
    return f"stdout: the listing, {counts[-1]}" if counts else "stdout: the listing"


def _built(stdout: str) -> str:
    return "stdout: the model's summary" if "model '" in stdout else "stdout: " + stdout[:80]


def _tracked(stdout: str) -> str:
    """The frames ``track --json`` printed, with their modes and any note."""
    frames = [json.loads(line) for line in stdout.splitlines() if line.strip()]
    shown = ", ".join(f"{f['name']} {f['mode']}" + (f" ({f['note']})" if f["note"] else "")
                      for f in frames)
    return f"stdout: {len(frames)} frame(s): {shown}"


def _sequence(folder: str, change: Callable[[Path], None]) -> Callable[[Path], None]:
    """A ``prepare``: ``folder``, a copy of the valid sequence ``frames``, then
    ``change(folder)``."""

    def prepare(work: Path) -> None:
        shutil.copytree(work / "frames", work / folder)
        change(work / folder)

    return prepare


def _timing(times: dict[str, float]) -> Callable[[Path], None]:
    """A ``change``: the sequence's ``meta.json`` at 30 fps with these frame times."""

    def change(folder: Path) -> None:
        doc = {"fps": 30.0, "frames": {name: {"t_s": t} for name, t in times.items()}}
        (folder / "meta.json").write_text(json.dumps(doc))

    return change


def _corrupt_png(path: Path) -> None:
    """``path`` with 1 KiB of garbage in the middle (inside its image data), its length
    kept."""
    data = path.read_bytes()
    middle = len(data) // 2
    path.write_bytes(data[:middle] + bytes(range(256)) * 4 + data[middle + 1024:])


# --- the bad files -------------------------------------------------------------------------


def _png_chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def _png_claiming(width: int, height: int) -> bytes:
    """A PNG whose (valid) header claims ``width`` x ``height`` colour pixels, with a tiny
    IDAT."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", ihdr)
            + _png_chunk(b"IDAT", zlib.compress(b"\x00" * 16)) + _png_chunk(b"IEND", b""))


def _bmp_claiming(width: int, height: int) -> bytes:
    """A 24-bit BMP whose header claims ``width`` x ``height``, with 10 bytes of pixels."""
    pixels = b"\x00" * 10
    info = struct.pack("<IiiHHIIiiII", 40, width, height, 1, 24, 0, 0, 2835, 2835, 0, 0)
    return b"BM" + struct.pack("<IHHI", 54 + len(pixels), 0, 0, 54) + info + pixels


def _image_of(work: Path, name: str, how: Callable[[np.ndarray], np.ndarray]) -> bytes:
    image = how(cv2.imread(str(work / name), cv2.IMREAD_COLOR))
    ok, data = cv2.imencode(Path(name).suffix, image)
    assert ok
    return data.tobytes()


def _stereo_values(work: Path) -> dict[str, Any]:
    """The valid rig as plain YAML values (lists), read from ``stereo.yaml``."""
    fs = cv2.FileStorage(str(work / "stereo.yaml"), cv2.FILE_STORAGE_READ)
    try:
        values: dict[str, Any] = {
            "image_width": int(fs.getNode("image_width").real()),
            "image_height": int(fs.getNode("image_height").real())}
        for key in ("K1", "D1", "K2", "D2", "R", "T"):
            values[key] = [float(v) for v in fs.getNode(key).mat().ravel()]
    finally:
        fs.release()
    return values


def _plain_stereo(work: Path, **changes: object) -> bytes:
    """The valid rig written by hand as plain YAML (``key: [values]``), some keys changed:
    a value given as ``str`` is written verbatim."""
    values = {**_stereo_values(work), **changes}
    lines = ["%YAML:1.0", "---"]
    for key, value in values.items():
        lines.append(f"{key}: {value if isinstance(value, str) else json.dumps(value)}")
    return ("\n".join(lines) + "\n").encode()


def _camera_info(work: Path) -> bytes:
    """The model-station camera as a ROS ``sensor_msgs/CameraInfo`` message (``rostopic
    echo``): ``width``/``height``, ``K``, ``D``, ``R``, ``P``, then the ``---`` marker."""
    fs = cv2.FileStorage(str(work / "camera.yaml"), cv2.FILE_STORAGE_READ)
    try:
        K = fs.getNode("camera_matrix").mat()
        D = fs.getNode("distortion_coefficients").mat().ravel()
        width, height = int(fs.getNode("image_width").real()), int(fs.getNode("image_height")
                                                                   .real())
    finally:
        fs.release()
    P = np.hstack([K, np.zeros((3, 1))])
    return (f"header:\n  seq: 0\n  frame_id: model_station\nheight: {height}\nwidth: {width}\n"
            f"distortion_model: plumb_bob\nD: {json.dumps(D.tolist())}\n"
            f"K: {json.dumps(K.ravel().tolist())}\nR: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, "
            f"1.0]\nP: {json.dumps(P.ravel().tolist())}\nbinning_x: 0\n---\n").encode()


def _camera_with(work: Path, key: str, value: str) -> bytes:
    """``camera.yaml`` with the scalar ``key`` set to ``value`` (verbatim)."""
    text = (work / "camera.yaml").read_text()
    text, n = re.subn(rf"^{key}:.*$", f"{key}: {value}", text, flags=re.M)
    assert n == 1, key
    return text.encode()


def _model_arrays(work: Path) -> tuple[dict[str, np.ndarray], dict[str, object]]:
    with np.load(work / "shirt.npz", allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files if k != "meta"}
        meta = json.loads(str(z["meta"]))
    return arrays, meta


def _model_bytes(arrays: dict[str, np.ndarray], meta: dict[str, object]) -> bytes:
    buf = io.BytesIO()
    np.savez_compressed(buf, meta=np.array(json.dumps(meta)), **arrays)
    return buf.getvalue()


def _model_with(work: Path, change: Callable[[dict[str, np.ndarray], dict[str, object]], None]
                ) -> bytes:
    arrays, meta = _model_arrays(work)
    change(arrays, meta)
    return _model_bytes(arrays, meta)


def _set_meta(key: str, value: object) -> Callable[[dict[str, np.ndarray], dict[str, object]],
                                                    None]:
    def change(arrays: dict[str, np.ndarray], meta: dict[str, object]) -> None:
        meta[key] = value

    return change


def _scale_points(factor: float) -> Callable[[dict[str, np.ndarray], dict[str, object]], None]:
    def change(arrays: dict[str, np.ndarray], meta: dict[str, object]) -> None:
        for key in ("points_in_mm", "points_out_mm", "outline_mm"):
            arrays[key] = arrays[key] * factor

    return change


def _transpose_mask(arrays: dict[str, np.ndarray], meta: dict[str, object]) -> None:
    arrays["mask"] = np.ascontiguousarray(arrays["mask"].T)


def _flipped_early(work: Path) -> bytes:
    """``shirt.npz`` with one byte of its second member's compressed data flipped (the first,
    the metadata, holds the build date, so its bytes change from build to build)."""
    data = bytearray((work / "shirt.npz").read_bytes())
    with zipfile.ZipFile(work / "shirt.npz") as z:
        info = z.getinfo("points_in_mm.npy")
    name_len, extra_len = struct.unpack_from("<HH", data, info.header_offset + 26)
    data[info.header_offset + 30 + name_len + extra_len + 100] ^= 0xFF
    return bytes(data)


def _deflate_zeros(n_bytes: int, chunk: int = 1 << 24) -> bytes:
    """A raw deflate stream of ``n_bytes`` zeros, built fast: after a full flush the
    compressor's output for another chunk of zeros is always the same bytes."""
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    zeros = bytes(chunk)
    first = c.compress(zeros) + c.flush(zlib.Z_FULL_FLUSH)
    repeat = c.compress(zeros) + c.flush(zlib.Z_FULL_FLUSH)
    full, rest = divmod(n_bytes, chunk)
    tail = zlib.compressobj(9, zlib.DEFLATED, -15)
    end = tail.compress(bytes(rest)) + tail.flush()
    return (first + repeat * (full - 1) + end) if full else end


def _zip64(members: Sequence[tuple[str, bytes, int, int]]) -> bytes:
    """A ZIP64 archive of deflated ``(name, stored bytes, crc, declared size)`` members."""
    out, directory = bytearray(), bytearray()
    for name, stored, crc, size in members:
        raw = name.encode()
        offset = len(out)
        extra = struct.pack("<HHQQ", 1, 16, size, len(stored))
        out += struct.pack("<4s5H3L2H", b"PK\x03\x04", 45, 0, 8, 0, 0, crc, 0xFFFFFFFF,
                           0xFFFFFFFF, len(raw), len(extra)) + raw + extra + stored
        extra = struct.pack("<HHQQQ", 1, 24, size, len(stored), offset)
        directory += struct.pack("<4s6H3L5H2L", b"PK\x01\x02", 45, 45, 0, 8, 0, 0, crc,
                                 0xFFFFFFFF, 0xFFFFFFFF, len(raw), len(extra), 0, 0, 0, 0,
                                 0xFFFFFFFF) + raw + extra
    start, end = len(out), len(out) + len(directory)
    out += directory
    out += struct.pack("<4sQ2H2L4Q", b"PK\x06\x06", 44, 45, 45, 0, 0, len(members),
                       len(members), len(directory), start)
    out += struct.pack("<4sLQL", b"PK\x06\x07", 0, end, 1)
    out += struct.pack("<4s4H2LH", b"PK\x05\x06", 0, 0, 0xFFFF, 0xFFFF, 0xFFFFFFFF,
                       0xFFFFFFFF, 0)
    return bytes(out)


def _deflated(name: str, data: bytes) -> tuple[str, bytes, int, int]:
    c = zlib.compressobj(6, zlib.DEFLATED, -15)
    return name, c.compress(data) + c.flush(), zlib.crc32(data), len(data)


def _npy(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, array, allow_pickle=False)
    return buf.getvalue()


BOMB_BYTES = 6 * 10**9


def _zip_bomb(work: Path) -> bytes:
    """The valid model whose ``photo_bgr`` member truly unpacks to 6 GB (an array header for
    that many bytes, then zeros): about 6 MB on disk."""
    arrays, meta = _model_arrays(work)
    members = [_deflated("meta.npy", _npy(np.array(json.dumps(meta))))]
    members += [_deflated(f"{k}.npy", _npy(v)) for k, v in arrays.items() if k != "photo_bgr"]
    text = f"{{'descr': '|u1', 'fortran_order': False, 'shape': ({BOMB_BYTES},), }}"
    text += " " * (-(len(text) + 11) % 64) + "\n"
    header = b"\x93NUMPY\x01\x00" + struct.pack("<H", len(text)) + text.encode("latin-1")
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    stored = c.compress(header) + c.flush(zlib.Z_FULL_FLUSH) + _deflate_zeros(BOMB_BYTES)
    crc = zlib.crc32(header)
    for _ in range(BOMB_BYTES >> 24):                      # the honest CRC of the zeros
        crc = zlib.crc32(bytes(1 << 24), crc)
    crc = zlib.crc32(bytes(BOMB_BYTES & ((1 << 24) - 1)), crc)
    members.append(("photo_bgr.npy", stored, crc, len(header) + BOMB_BYTES))
    return _zip64(members)


def _bad_library(work: Path) -> None:
    """``badlib``: the valid model, a text file named like a model and a model of a newer
    format version."""
    lib = work / "badlib"
    lib.mkdir()
    shutil.copyfile(work / "lib" / "shirt.npz", lib / "shirt.npz")
    shutil.copyfile(work / "lib" / "index.json", lib / "index.json")
    (lib / "notes.npz").write_text("garment No. 3: red T-shirt\n")
    (lib / "future.npz").write_bytes(_model_with(work, _set_meta("version", 99)))


IDENTIFY = ("--stereo", "stereo.yaml", "--right", "right.png", "--left", "left.png")

BUILT = ("README.md", "photo.bmp", "shirt.model")
"""``built``: a folder of what ``build --out built/shirt.model`` writes, with a README and a
photo beside it, no index."""


def _built_folder(work: Path) -> None:
    folder = work / "built"
    folder.mkdir()
    shutil.copyfile(work / "shirt.npz", folder / "shirt.model")
    shutil.copyfile(work / "photo.bmp", folder / "photo.bmp")
    (folder / "README.md").write_text("garments of line 3\n")


def _duplicate_library(work: Path) -> None:
    """``duplib``: two files holding the model ``shirt`` (``shirt.model``, ``shirt_copy.npz``)."""
    folder = work / "duplib"
    folder.mkdir()
    shutil.copyfile(work / "shirt.npz", folder / "shirt.model")
    shutil.copyfile(work / "shirt.npz", folder / "shirt_copy.npz")


def _holds_only(folder: str, names: Sequence[str]) -> Callable[[Path], str | None]:
    """A ``verify``: ``folder`` holds exactly ``names`` (a read wrote nothing into it)."""

    def verify(work: Path) -> str | None:
        found = sorted(p.name for p in (work / folder).iterdir())
        return None if found == sorted(names) else f"{folder} holds {found}"

    return verify


def _stdout(stdout: str) -> str:
    return "stdout: " + " ".join(stdout.split())


def _index_of(work: Path, library: str) -> dict[str, Any]:
    return json.loads((work / library / "index.json").read_text())


def _library_copy(library: str, change: Callable[[dict[str, Any]], None]
                  ) -> Callable[[Path], None]:
    """A ``prepare``: ``library``, a copy of ``lib`` (the model file keeps its size and
    time, so that the index still vouches for it) whose index is changed by ``change``."""

    def prepare(work: Path) -> None:
        shutil.copytree(work / "lib", work / library, copy_function=shutil.copy2)
        index = _index_of(work, library)
        change(index)
        (work / library / "index.json").write_text(json.dumps(index, indent=1) + "\n")

    return prepare


def _strip_descriptors(index: dict[str, Any]) -> None:
    for entry in index["models"].values():
        del entry["descriptor"]


def _corrupt_descriptor(index: dict[str, Any]) -> None:
    index["models"]["shirt"]["descriptor"]["colour_bins"] = "x"


def _described_as_lib(library: str) -> Callable[[Path], str | None]:
    """A ``verify``: ``library``'s index holds the entries of ``lib``'s, the same descriptors
    included (described again from the same file), nothing lost."""

    def verify(work: Path) -> str | None:
        try:
            index = _index_of(work, library)
        except (OSError, ValueError) as exc:
            return f"{library}/index.json unreadable ({exc})"
        if index["models"] != _index_of(work, "lib")["models"]:
            return f"{library}/index.json is not lib's: {sorted(index['models'])}"
        return None

    return verify


DAMAGED_LABELS = '{"format": "photomodel-labels", "version": 1, "labels": {"PM-1": '
"""A label map cut short."""


def _damaged_labels(library: str) -> tuple[Callable[[Path], None],
                                           Callable[[Path], str | None]]:
    """A ``prepare`` writing ``library``, a copy of ``lib`` with a damaged ``labels.json``,
    and a ``verify`` that the file is left as it was."""

    def prepare(work: Path) -> None:
        shutil.copytree(work / "lib", work / library, copy_function=shutil.copy2)
        (work / library / "labels.json").write_text(DAMAGED_LABELS)

    def verify(work: Path) -> str | None:
        path = work / library / "labels.json"
        return None if path.read_text() == DAMAGED_LABELS else f"{library}/labels.json changed"

    return prepare, verify


def _still_empty(library: str) -> Callable[[Path], str | None]:
    def verify(work: Path) -> str | None:
        found = sorted(p.name for p in (work / library).iterdir())
        return f"{library} holds {found}" if found else None

    return verify


def _keeps(name: str, content: str) -> tuple[Callable[[Path], None],
                                             Callable[[Path], str | None]]:
    def prepare(work: Path) -> None:
        (work / name).write_text(content)

    def verify(work: Path) -> str | None:
        path = work / name
        return None if path.is_file() and path.read_text() == content else f"{name} was changed"

    return prepare, verify


CAL_PAIRS = "D/calibration/pairs"
CAL_PATTERN = "chessboard:9x6:25"          # the simulator's board (``CALIBRATION_BOARD``)


def _pairs(folder: str, ids: Sequence[str] = ("0000", "0001", "0002"),
           change: Callable[[Path], None] | None = None) -> Callable[[Path], None]:
    """A ``prepare``: ``folder``, a copy of the simulated pair folders ``ids``, then
    ``change(folder)``."""

    def prepare(work: Path) -> None:
        for vid in ids:
            shutil.copytree(work / CAL_PAIRS / vid, work / folder / vid)
        if change is not None:
            change(work / folder)

    return prepare


def _resized(name: str, size: tuple[int, int]) -> Callable[[Path], None]:
    def change(folder: Path) -> None:
        image = cv2.imread(str(folder / name), cv2.IMREAD_COLOR)
        assert cv2.imwrite(str(folder / name), cv2.resize(image, size))

    return change


def _videos(stem: str, *sizes: tuple[int, int]) -> Callable[[Path], None]:
    """A ``prepare``: Motion-JPEG videos ``STEM0.avi``, ``STEM1.avi``, ... of these sizes,
    three plain frames each."""

    def prepare(work: Path) -> None:
        for k, size in enumerate(sizes):
            writer = cv2.VideoWriter(str(work / f"{stem}{k}.avi"),
                                     cv2.VideoWriter_fourcc(*"MJPG"), 30.0, size)
            for _ in range(3):
                writer.write(np.full((size[1], size[0], 3), 120, np.uint8))
            writer.release()

    return prepare


def _plain_views(work: Path) -> None:
    """``plain/``: three plain grey 640 x 480 views, no board in them."""
    (work / "plain").mkdir()
    for k in range(3):
        assert cv2.imwrite(str(work / "plain" / f"{k:04d}.png"),
                           np.full((480, 640, 3), 70 + 60 * k, np.uint8))


def _no_calibration(out: str, kept: bool = False) -> Callable[[Path], str | None]:
    """A ``verify``: nothing named after ``out`` beside it (the file itself unless ``kept``,
    its ``.coverage.png`` and ``.errors.png``, a temporary file)."""

    def verify(work: Path) -> str | None:
        path = work / out
        left = sorted(p.name for p in path.parent.glob(f"*{path.stem}*")
                      if not (kept and p.name == path.name))
        return f"left behind {', '.join(left)}" if left else None

    return verify


def _locked_run(work: Path) -> None:
    """``run/``, a run directory with a record, whose lock ``run/.lock`` the script holds
    while the cases run (as a running ``experiment`` does)."""
    (work / "run").mkdir()
    (work / "run" / "records.csv").write_text("kept\n")


# --- the table of cases --------------------------------------------------------------------


def cases() -> list[Case]:
    """Every case, grouped as the tables are."""
    sim = ("--garments", "No.3", "--scenes", "1")
    exp = ("--garments", "No.3", "--trials", "1", "--workers", "1", "--no-report")
    keep_prepare, keep_verify = _keeps("notes.txt", "precious\n")
    old_cal = "%YAML:1.0\n# the model camera, calibrated last week\n"
    cal_keep_prepare, cal_keep_verify = _keeps("cal_old.yaml", old_cal)
    no_plots = _no_calibration("cal_old.yaml", kept=True)
    labels_prepare, labels_verify = _damaged_labels("lib_labels")
    labels_id_prepare, labels_id_verify = _damaged_labels("lib_labels_id")

    def stereo(name: str, pairs: str, pattern: str = CAL_PATTERN, out: str | None = None,
               **kwargs: Any) -> Case:
        """``calibrate stereo``, by default into ``out/cal-SLUG.yaml``, left unwritten."""
        if out is None:
            out = "out/cal-" + re.sub(r"[^a-z0-9]+", "-", name.lower()).strip("-") + ".yaml"
        kwargs.setdefault("verify", _no_calibration(out))
        return _case("Calibrating", name, "calibrate", "stereo", "--pairs", pairs, "--pattern",
                     pattern, "--out", out, **kwargs)

    huge_png, huge_bmp = _png_claiming(60000, 60000), _bmp_claiming(60000, 60000)
    return [
        # images
        _case("Images", "missing file", "locate", "--right", "missing.png"),
        _case("Images", "empty file", "locate", "--right", "empty.png",
              prepare=_writes("empty.png", lambda w: b"")),
        _case("Images", "not an image (text)", "locate", "--right", "notes.png",
              prepare=_writes("notes.png", lambda w: b"right camera, shot on Monday\n")),
        _case("Images", f"PNG header claiming 60000 x 60000 ({len(huge_png)}-byte file)",
              "locate", "--right", "huge.png", prepare=_writes("huge.png", lambda w: huge_png)),
        _case("Images", f"BMP header claiming 60000 x 60000 ({len(huge_bmp)}-byte file)",
              "build", "--photo", "huge.bmp", prepare=_writes("huge.bmp", lambda w: huge_bmp)),
        _case("Images", "truncated PNG (first half)", "locate", "--right", "truncated.png",
              prepare=_writes("truncated.png", lambda w: (w / "right.png").read_bytes()[
                  :len((w / "right.png").read_bytes()) // 2])),
        _case("Images", "greyscale PNG", "locate", "--right", "grey.png",
              prepare=_writes("grey.png", lambda w: _image_of(
                  w, "right.png", lambda im: cv2.cvtColor(im, cv2.COLOR_BGR2GRAY)))),
        _case("Images", "a directory instead of a file", "locate", "--right",
              "D/scenes/paper_No.3_0000"),
        # calibrations
        _case("Calibrations", "stereo file missing", "locate", "--stereo", "missing.yaml"),
        _case("Calibrations", "top-level JSON array", "locate", "--stereo", "array.json",
              prepare=_writes("array.json", lambda w: json.dumps([_stereo_values(w)]).encode())),
        _case("Calibrations", "`K1: \"abc\"`", "locate", "--stereo", "k1_text.yaml",
              prepare=_writes("k1_text.yaml", lambda w: _plain_stereo(w, K1='"abc"'))),
        _case("Calibrations", "T as a nested list of rows (`[[119.54...], [0.0], [10.47...]]`)",
              "locate", "--stereo", "nested_t.yaml", "--json", expected_code=0, summary=_json_found,
              prepare=_writes("nested_t.yaml", lambda w: _plain_stereo(
                  w, T="[[" + "], [".join(f"{t!r}" for t in _stereo_values(w)["T"]) + "]]"))),
        _case("Calibrations", "T in metres", "locate", "--stereo", "t_metres.yaml", "--json",
              expected_code=0, summary=_json_found,
              prepare=_writes("t_metres.yaml", lambda w: _plain_stereo(
                  w, T=[t / 1000 for t in _stereo_values(w)["T"]]))),
        _case("Calibrations", "focal length 1e12 px", "locate", "--stereo", "focal.yaml",
              prepare=_writes("focal.yaml", lambda w: _plain_stereo(
                  w, K1=[1e12, 0, 322.1, 0, 1e12, 238.4, 0, 0, 1]))),
        _case("Calibrations", "negative image_width", "locate", "--stereo", "width.yaml",
              prepare=_writes("width.yaml", lambda w: _plain_stereo(w, image_width=-640))),
        _case("Calibrations", "R not a rotation (a mirror, det -1)", "locate", "--stereo",
              "mirror_r.yaml", prepare=_writes("mirror_r.yaml", lambda w: _plain_stereo(
                  w, R=[1, 0, 0, 0, 1, 0, 0, 0, -1]))),
        _case("Calibrations", "model station `distance_mm: .inf`", "build", "--camera",
              "inf_distance.yaml", prepare=_writes("inf_distance.yaml", lambda w: _camera_with(
                  w, "distance_mm", ".inf"))),
        _case("Calibrations", "ROS CameraInfo message (`width`, `height`, `K`, `D`)", "build",
              "--camera", "camera_info.yaml", expected_code=0, summary=_built,
              prepare=_writes("camera_info.yaml", _camera_info)),
        # calibrating (`photomodel calibrate`, the simulated chessboard views)
        stereo("two pairs (3 needed)", "cal_two", prepare=_pairs("cal_two", ("0000", "0001"))),
        stereo("wrong board size (`7x5` for the 9x6 board)", CAL_PAIRS, "chessboard:7x5:25"),
        stereo("malformed `--pattern` (`25mm`)", CAL_PAIRS, "chessboard:9x6:25mm"),
        stereo("one left view of another size (800 x 600)", "cal_sizes",
               prepare=_pairs("cal_sizes", change=_resized("0001/left.png", (800, 600)))),
        stereo("a pair folder without its left.png", "cal_noleft",
               prepare=_pairs("cal_noleft", change=lambda d: (d / "0002" / "left.png").unlink())),
        _case("Calibrating", "board in no view (plain grey images), over an existing --out "
              "file", "calibrate", "camera", "--images", "plain", "--plane",
              "D/calibration/station/plane.png", "--pattern", CAL_PATTERN, "--out",
              "cal_old.yaml", prepare=lambda w: (_plain_views(w), cal_keep_prepare(w)),
              verify=lambda w: cal_keep_verify(w) or no_plots(w)),
        stereo("`--out` inside a file (`cal_notes.txt/rig.yaml`)", CAL_PAIRS,
               out="cal_notes.txt/rig.yaml",
               prepare=_writes("cal_notes.txt", lambda w: b"not a folder\n"),
               verify=lambda w: None if (w / "cal_notes.txt").read_bytes() == b"not a folder\n"
               else "cal_notes.txt was changed"),
        # model files
        _case("Model files", "missing", "locate", "--model", "missing.npz"),
        _case("Model files", "not a zip (text)", "locate", "--model", "notes.npz",
              prepare=_writes("notes.npz", lambda w: b"garment No. 3: red T-shirt\n")),
        _case("Model files", "one byte flipped early in the archive", "locate", "--model",
              "flipped.npz", prepare=_writes("flipped.npz", _flipped_early)),
        _case("Model files", "format version a list (`[2]`)", "locate", "--model",
              "version_list.npz", prepare=_writes("version_list.npz", lambda w: _model_with(
                  w, _set_meta("version", [2])))),
        _case("Model files", "format version null", "locate", "--model", "version_null.npz",
              prepare=_writes("version_null.npz", lambda w: _model_with(
                  w, _set_meta("version", None)))),
        _case("Model files", "zip bomb: a member that unpacks to 6 GB (a 5.9 MB file)", "locate",
              "--model", "bomb.npz", prepare=_writes("bomb.npz", _zip_bomb)),
        _case("Model files", "mask of another shape than the photo crop", "locate", "--model",
              "bad_mask.npz", prepare=_writes("bad_mask.npz", lambda w: _model_with(
                  w, _transpose_mask))),
        _case("Model files", "model points scaled by 1e6, with --overlay", "locate", "--model",
              "scaled.npz", "--overlay", "out/scaled.png", verify=_absent("out/scaled.png"),
              prepare=_writes("scaled.npz", lambda w: _model_with(w, _scale_points(1e6)))),
        # model library
        _case("Model library", "a text file and a newer-format model in the library",
              "models", "list", "--models", "badlib", expected_code=0, summary=_model_count,
              prepare=_bad_library),
        _case("Model library", "an index of an older photomodel (no model descriptors): "
              "upgraded, nothing lost", "identify", "--models", "oldlib", *IDENTIFY, "--json",
              expected_code=0, summary=_json_found,
              prepare=_library_copy("oldlib", _strip_descriptors),
              verify=_described_as_lib("oldlib")),
        _case("Model library", "a corrupt descriptor in the index (`\"colour_bins\": \"x\"`): "
              "noted, described again", "identify", "--models", "baddesc", *IDENTIFY, "--json",
              expected_code=0, summary=_json_found,
              prepare=_library_copy("baddesc", _corrupt_descriptor),
              verify=_described_as_lib("baddesc")),
        _case("Model library", "`identify --models` on a folder without model files",
              "identify", "--models", "nomodels", *IDENTIFY,
              prepare=lambda w: (w / "nomodels").mkdir(), verify=_still_empty("nomodels")),
        _case("Model library", "`models list` on a folder without model files", "models",
              "list", "--models", "nomodels_list", expected_code=0, summary=_stdout,
              prepare=lambda w: (w / "nomodels_list").mkdir(),
              verify=_still_empty("nomodels_list")),
        _case("Model library", "a folder of `build --out built/shirt.model` output with a "
              "README and a photo, no index: a library as it is, nothing written into it",
              "identify", "--models", "built", *IDENTIFY, "--json", expected_code=0,
              summary=_json_found, prepare=_built_folder, verify=_holds_only("built", BUILT)),
        _case("Model library", "two files holding one model name (`shirt.model`, "
              "`shirt_copy.npz`)", "models", "list", "--models", "duplib", expected_code=0,
              summary=_model_count, prepare=_duplicate_library,
              verify=_holds_only("duplib", ("shirt.model", "shirt_copy.npz"))),
        _case("Model library", "model name with a newline", "models", "add", "--models",
              "lib_nl", "shirt.npz", "--name", "two\nlines", verify=_no_model_in("lib_nl")),
        _case("Model library", "model name with a right-to-left override", "models", "add",
              "--models", "lib_rtl", "shirt.npz", "--name", "evil\u202eman",
              verify=_no_model_in("lib_rtl")),
        _case("Model library", "`models label` naming a model the library does not hold",
              "models", "label", "--models", "lib", "jeans", "PM-7",
              verify=_absent("lib/labels.json")),
        _case("Model library", "a label map cut short (`labels.json`), with `models label`",
              "models", "label", "--models", "lib_labels", "shirt", "PM-7",
              prepare=labels_prepare, verify=labels_verify),
        _case("Model library", "a label map cut short (`labels.json`): identify warns, reads "
              "the pair as without a map", "identify", "--models", "lib_labels_id", *IDENTIFY,
              "--json", expected_code=0, summary=_json_found,
              prepare=labels_id_prepare, verify=labels_id_verify),
        # tracking (`photomodel track`, the valid sequence `frames/`)
        _case("Tracking", "a frame of another size mid-sequence (000001/right.png 320 x 240)",
              "track", "--frames", "trk_size", "--json", expected_code=1, summary=_tracked,
              prepare=_sequence("trk_size", _resized("000001/right.png", (320, 240)))),
        _case("Tracking", "a frame without its left.png", "track", "--frames", "trk_noleft",
              "--json", expected_code=1, summary=_tracked,
              prepare=_sequence("trk_noleft", lambda d: (d / "000001" / "left.png").unlink())),
        _case("Tracking", "a corrupt frame (1 KiB of garbage amid 000001/right.png)",
              "track", "--frames", "trk_corrupt", "--json", expected_code=1, summary=_tracked,
              prepare=_sequence("trk_corrupt", lambda d: _corrupt_png(d / "000001" /
                                                                     "right.png"))),
        _case("Tracking", "a time that goes back (meta.json: 000002 at 0.05 s after 000001 at "
              "0.1 s)", "track", "--frames", "trk_back", "--json", expected_code=0,
              summary=_tracked, prepare=_sequence("trk_back", _timing(
                  dict(zip(TRACK_FRAMES, (0.0, 0.1, 0.05), strict=True))))),
        _case("Tracking", "an unreadable timing file (meta.json not JSON)", "track", "--frames",
              "trk_meta", prepare=_sequence("trk_meta", lambda d: (d / "meta.json").write_text(
                  "fps: 30\n"))),
        _case("Tracking", "a folder with no frames", "track", "--frames", "trk_empty",
              prepare=lambda w: (w / "trk_empty").mkdir()),
        _case("Tracking", "`--frames` a file", "track", "--frames", "notes.txt",
              prepare=keep_prepare, verify=keep_verify),
        # camera sources (`photomodel serve --source`: refused before the service starts)
        _case("Camera sources", "unknown kind", "serve", "--source", "usb:0"),
        _case("Camera sources", "a device that does not open", "serve", "--source",
              "opencv:97,98"),
        _case("Camera sources", "one camera only", "serve", "--source", "opencv:0"),
        _case("Camera sources", "a replay folder that is not there", "serve", "--source",
              "replay:nowhere"),
        _case("Camera sources", "views of different sizes (640 x 480 and 320 x 240 videos)",
              "serve", "--source", "opencv:mix0.avi,mix1.avi",
              prepare=_videos("mix", (640, 480), (320, 240))),
        _case("Camera sources", "views of another size than the calibration's", "serve",
              "--source", "opencv:small0.avi,small1.avi",
              prepare=_videos("small", (320, 240), (320, 240))),
        _case("Camera sources", "`sim` with another rig than the simulated one", "serve",
              "--stereo", "src_rig.yaml", "--source", "sim",
              prepare=_writes("src_rig.yaml", lambda w: _plain_stereo(w, T=[-100.0, 0, 0]))),
        _case("Camera sources", "`sim` of an unknown garment", "serve", "--source",
              "sim:No.99"),
        _case("Camera sources", "GenICam cameras without a GenTL producer", "serve",
              "--source", "genicam:0,1"),
        _case("Camera sources", "a negative skew bound", "serve", "--source", "sim",
              "--max-skew-ms", "-1"),
        # options
        _case("Options", "`--min-score` above 1", "locate", "--min-score", "2"),
        _case("Options", "negative seed", "simulate", "--out", "sim_seed", *sim, "--seed", "-1",
              verify=_absent("sim_seed")),
        _case("Options", "a billion scenes", "simulate", "--out", "sim_many", "--garments",
              "No.3", "--scenes", "1000000000", verify=_absent("sim_many")),
        _case("Options", "zero generations", "experiment", "--out", "exp_gen0", *exp,
              "--generations", "0", verify=_absent("exp_gen0")),
        _case("Options", "empty x range (`--x-mm 100 -100`)", "locate", "--x-mm", "100", "-100"),
        _case("Options", "sampling step of 1 m", "build", "--step-mm", "1000",
              verify=_absent("out/options-sampling-step-of-1-m.npz")),
        *_register_cases(),
        *_security_cases(),
        _case("Options", "unknown option", "locate", "--bogus"),
        _case("Options", "`simulate --force` onto a file", "simulate", "--out", "notes.txt", *sim,
              "--force", prepare=keep_prepare, verify=keep_verify),
        _case("Options", "unknown sequence kind", "simulate", "--out", "seq_kind",
              "--sequences", "approach,orbit", verify=_absent("seq_kind")),
        _case("Options", "a table of seven garments", "simulate", "--out", "table7", "--table",
              "7", verify=_absent("table7")),
        _case("Options", "`cell --tables` with garment names for the count", "cell",
              "--tables", "2", "--garments", "No.3"),
        _case("Options", "frame rate 0", "simulate", "--out", "seq_fps0", "--sequences",
              "conveyor", "--fps", "30,0", verify=_absent("seq_fps0")),
        _case("Options", "frame rate not a number", "simulate", "--out", "seq_fps_text",
              "--sequences", "conveyor", "--fps", "thirty", verify=_absent("seq_fps_text")),
        _case("Options", "`simulate --sequences` into a folder of other files", "simulate",
              "--out", "seq_old", "--sequences", "lost", "--force",
              prepare=_writes("seq_old/notes.txt", lambda w: b"precious\n"),
              verify=lambda w: None if [p.name for p in (w / "seq_old").iterdir()]
              == ["notes.txt"] else "seq_old was changed"),
        _case("Options", "experiment into a directory another run holds", "experiment",
              "--out", "run", *exp, prepare=_locked_run,
              verify=lambda w: None if (w / "run" / "records.csv").read_text() == "kept\n"
              else "run/records.csv was changed"),
        _case("Options", "`certs` for a host name with a space", "certs", "--out", "pki_bad",
              "--host", "cell 7", verify=_absent("pki_bad")),
        _case("Options", "`certs` over certificates already there, without `--force`", "certs",
              "--out", "pki_old", "--host", "cell7",
              prepare=_writes("pki_old/server.key", lambda w: b"the cell's key\n"),
              verify=lambda w: None if [p.name for p in (w / "pki_old").iterdir()]
              == ["server.key"] and (w / "pki_old" / "server.key").read_bytes()
              == b"the cell's key\n" else "pki_old was changed"),
        _case("Options", "`audit` of a library without an audit trail", "audit", "--models",
              "lib"),
        _case("Options", "`audit` of a trail with a line that is not JSON", "audit", "--log",
              "trail.jsonl", prepare=_writes("trail.jsonl", lambda w: b'{"action":"login"}\n'
                                             b"login by alice\n")),
    ]


# --- running -------------------------------------------------------------------------------


def _photomodel(argv: Sequence[str], cwd: Path, env: dict[str, str],
                timeout_s: float = TIMEOUT_S) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "photomodel", *argv], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout_s, check=False)


def _environment(work: Path) -> dict[str, str]:
    """The user's environment, with no threshold file of theirs (``found`` is the shipped
    threshold's) and no Python warnings filter of theirs."""
    env = dict(os.environ)
    env["PHOTOMODEL_THRESHOLD"] = str(work / "no-threshold.json")
    env.pop("GENICAM_GENTL64_PATH", None)     # no GenTL producer of theirs either
    env.pop("PYTHONWARNINGS", None)
    return env


def setup(work: Path, env: dict[str, str]) -> None:
    """The valid files: a simulated dataset of No.3, its model and a library holding it.

    Raises
    ------
    RuntimeError
        A command of the valid setup failed (its stderr).
    """
    steps = [["simulate", "--out", "D", "--garments", "No.3", "--scenes", "1", "--seed", "1",
              "--calibration-views", "3"],
             ["build", "--photo", "D/models/No.3/photo.bmp", "--background",
              "D/models/No.3/background.bmp", "--camera", "D/model_camera.yaml", "--out",
              "shirt.npz", "--name", "shirt", "--no-preview"],
             ["models", "add", "--models", "lib", "shirt.npz"]]
    for argv in steps:
        done = _photomodel(argv, work, env)
        if done.returncode != 0:
            raise RuntimeError(f"photomodel {' '.join(argv)} failed:\n{done.stderr}")
    scene = work / "D" / "scenes" / "paper_No.3_0000"
    for source, name in ((work / "D" / "stereo.yaml", "stereo.yaml"),
                         (work / "D" / "model_camera.yaml", "camera.yaml"),
                         (work / "D" / "models" / "No.3" / "photo.bmp", "photo.bmp"),
                         (work / "D" / "models" / "No.3" / "background.bmp", "background.bmp"),
                         (scene / "right.png", "right.png"), (scene / "left.png", "left.png")):
        shutil.copyfile(source, work / name)
    for frame in TRACK_FRAMES:
        (work / "frames" / frame).mkdir(parents=True)
        for side in ("right.png", "left.png"):
            shutil.copyfile(scene / side, work / "frames" / frame / side)
    (work / "out").mkdir()


def _clean(text: str, work: Path) -> str:
    """``text`` with the work directory as ``DIR`` and process ids as ``PID``."""
    for root in sorted({str(work), os.path.realpath(work)}, key=len, reverse=True):
        text = text.replace(root + os.sep, "DIR/").replace(root, "DIR")
    return re.sub(r"\bprocess \d+", "process PID", text)


def run_case(case: Case, work: Path, env: dict[str, str]) -> Outcome:
    """Run one prepared case and judge it."""
    start = time.perf_counter()
    problems: list[str] = []
    try:
        done = _photomodel(case.argv, work, env)
        code, stdout, stderr = done.returncode, done.stdout, done.stderr
    except subprocess.TimeoutExpired as exc:
        code, stdout = None, ""
        stderr = (exc.stderr or b"").decode() if isinstance(exc.stderr, bytes) else \
            (exc.stderr or "")
        problems.append(f"timed out after {TIMEOUT_S:g} s")
    seconds = time.perf_counter() - start
    if "Traceback" in stderr or "Traceback" in stdout:
        problems.append("printed a traceback")
    if code is not None and code != case.expected_code:
        problems.append(f"exit code {code}, expected {case.expected_code}")
    if case.verify is not None:
        problem = case.verify(work)
        if problem:
            problems.append(problem)
    summary = ""
    if case.summary is not None and code in (0, 1):
        try:
            summary = case.summary(stdout)
        except (ValueError, KeyError, TypeError) as exc:
            problems.append(f"unexpected stdout ({exc!r})")
    return Outcome(case, code, _clean(stderr, work), _clean(summary, work), tuple(problems),
                   seconds)


@contextlib.contextmanager
def _run_lock_held(directory: Path) -> Iterator[None]:
    """Hold ``directory/.lock`` as a running experiment does (``fcntl.flock``)."""
    import fcntl

    fd = os.open(directory / ".lock", os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        os.write(fd, f"{os.getpid()}\n".encode())
        yield
    finally:
        os.close(fd)


def run_cases(selected: Sequence[Case], work: Path, jobs: int = 2) -> list[Outcome]:
    """Set up ``work``, prepare and run ``selected`` (``jobs`` at a time), in their order."""
    env = _environment(work)
    setup(work, env)
    for case in selected:
        if case.prepare is not None:
            case.prepare(work)
    with contextlib.ExitStack() as stack:
        if (work / "run").is_dir():
            stack.enter_context(_run_lock_held(work / "run"))
        # The cases that run a whole search first, so that the pool ends together.
        order = sorted(range(len(selected)), key=lambda i: selected[i].expected_code != 0)
        with ThreadPoolExecutor(max_workers=jobs) as pool:
            futures = {i: pool.submit(run_case, selected[i], work, env) for i in order}
            return [futures[i].result() for i in range(len(selected))]


# --- the table -----------------------------------------------------------------------------


def _cell(text: str) -> str:
    """``text`` for a table cell: non-printable characters escaped, ``|`` escaped."""
    text = "".join(c if c.isprintable() else ascii(c)[1:-1] for c in text)
    return text.replace("|", "\\|")


def _code_span(text: str) -> str:
    text = _cell(text)
    fence = "``" if "`" in text else "`"
    pad = " " if text.startswith("`") or text.endswith("`") else ""
    return f"{fence}{pad}{text}{pad}{fence}"


def _seen(outcome: Outcome) -> str:
    lines = [line[:MAX_LINE_CHARS] + ("…" if len(line) > MAX_LINE_CHARS else "")
             for line in outcome.stderr.strip().splitlines() if line.strip()]
    shown = [_code_span(line) for line in lines]
    if len(lines) > 1:
        shown.insert(0, f"**{len(lines)} lines:**")
    if outcome.stdout_summary:
        shown.append(f"({_cell(outcome.stdout_summary)})")
    if not lines and not outcome.stdout_summary:
        shown.append("(nothing on stderr)")
    if outcome.problems:
        shown.append(f"**FAILS: {_cell('; '.join(outcome.problems))}**")
    return "<br>".join(shown)


def render(outcomes: Sequence[Outcome]) -> str:
    """The markdown document: how it was made, what ``…`` stands for, one table a kind."""
    out = [
        "# What the user sees for bad input",
        "",
        f"Generated by `{GENERATE}`; `tests/test_bad_inputs_table.py` fails when "
        "this file and what the code does differ. Each case runs `photomodel` as a real "
        "process on one bad file or option, the rest of the command valid; the script fails "
        "when a case shows a traceback, exits with another code than the one listed here, or "
        "replaces or half-writes a file. **No case may show a traceback.** Exit code 2 is an "
        "input error (one line, `photomodel: error: FILE: problem`, nothing written); 0 means "
        "the input was read, perhaps with a warning line; 1 (`track`) means that some frames "
        "could not be read (one line each) and the others were tracked.",
        "",
        "The valid setup (in a temporary directory, shown as `DIR`): `photomodel simulate "
        "--out D --garments No.3 --scenes 1 --seed 1 --calibration-views 3` (its "
        "`stereo.yaml`, `model_camera.yaml` as `camera.yaml`, the model photos `photo.bmp`, "
        "`background.bmp` and the scene's `right.png`, `left.png` copied beside it; "
        f"`{CAL_PAIRS}` holds three views of a 9x6 chessboard, `{CAL_PATTERN}`, by each hand "
        "camera, and the `cal_*` folders are copies of some of them, changed as the case "
        "says), its model built into `shirt.npz` and added to the library `lib`; the sequence "
        f"`frames/` holds {len(TRACK_FRAMES)} frames ({', '.join(TRACK_FRAMES)}), each the "
        "scene's pair, and the `trk_*` folders are copies of it, changed as the case says. "
        "In the commands,",
        "",
    ]
    for cmd, valid in VALID.items():
        words = " ".join(f"{o} {v.format(slug='CASE')}" for o, v in valid)
        out.append(f"- `{cmd} …` is `photomodel {cmd} {words}`, the option shown replacing "
                   "its valid value or added;")
    out.append("- other commands are shown in full.")
    for group in GROUPS:
        rows = [o for o in outcomes if o.case.group == group]
        if not rows:
            continue
        out += ["", f"## {group}", "", "| case | command | exit code | what the user sees |",
                "|---|---|---:|---|"]
        for o in rows:
            code = "timeout" if o.code is None else str(o.code)
            out.append(f"| {_cell(o.case.name)} | {_code_span('photomodel ' + o.case.short)} "
                       f"| {code} | {_seen(o)} |")
    return "\n".join(out) + "\n"


# --- command line --------------------------------------------------------------------------


def main(argv: Sequence[str] | None = None) -> int:
    """Run the cases; write, check or print the table. Returns the exit code."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    action = parser.add_mutually_exclusive_group()
    action.add_argument("--out", type=Path, help="write the table to this file")
    action.add_argument("--check", type=Path,
                        help="exit 1 with a diff if this file differs from the table")
    parser.add_argument("--only", metavar="TEXT",
                        help="run only the cases whose group or name contains TEXT "
                             "(case-insensitive; the table goes to stdout)")
    parser.add_argument("--jobs", type=int, default=2, help="cases run at a time (default 2)")
    parser.add_argument("--keep", type=Path, metavar="DIR",
                        help="set up and run in DIR (must not exist) and keep it, to rerun a "
                             "case by hand")
    parser.add_argument("--verbose", action="store_true",
                        help="print each case's seconds to stderr")
    args = parser.parse_args(argv)
    selected = cases()
    if args.only:
        text = args.only.lower()
        selected = [c for c in selected if text in f"{c.group} {c.name}".lower()]
        if not selected:
            parser.error(f"--only {args.only!r}: no such case")
        if args.out or args.check:
            parser.error("--only prints the table; it cannot --out or --check")
    start = time.perf_counter()
    with contextlib.ExitStack() as stack:
        if args.keep:
            args.keep.mkdir(parents=True)
            work = args.keep.resolve()
        else:
            work = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="bad-inputs-")))
        outcomes = run_cases(selected, work, jobs=args.jobs)
    table = render(outcomes)
    failed = [o for o in outcomes if o.problems]
    status = 0
    if args.out:
        args.out.write_text(table)
    elif args.check:
        old = args.check.read_text() if args.check.exists() else ""
        if old != table:
            sys.stdout.writelines(difflib.unified_diff(
                old.splitlines(keepends=True), table.splitlines(keepends=True),
                str(args.check), "regenerated"))
            print(f"{args.check} is out of date: regenerate it with {GENERATE}",
                  file=sys.stderr)
            status = 1
    else:
        sys.stdout.write(table)
    if args.verbose:
        for o in sorted(outcomes, key=lambda o: -o.seconds):
            print(f"{o.seconds:6.1f} s  {o.case.group} / {o.case.name}", file=sys.stderr)
    for o in failed:
        print(f"FAIL {o.case.group} / {o.case.name}: {'; '.join(o.problems)}\n"
              f"     photomodel {' '.join(_shell_word(a) for a in o.case.argv)}",
              file=sys.stderr)
    print(f"{len(outcomes)} case(s), {len(failed)} failed, "
          f"{time.perf_counter() - start:.1f} s", file=sys.stderr)
    return 1 if failed else status


if __name__ == "__main__":
    sys.exit(main())
