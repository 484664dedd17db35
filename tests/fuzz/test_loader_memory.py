"""Memory the loaders spend on the worst inputs: each case runs in a fresh interpreter whose
address space is bounded (RLIMIT_AS at its size plus a margin) after a warm-up load, and
reports its peak RSS before and after; ``build/loader_memory.json`` keeps the figures."""

from __future__ import annotations

import json
import struct
import zlib
from pathlib import Path
from typing import Any

import pytest
from fuzz_helpers import (
    bmp_with_header,
    bomb_archive,
    deflate_zeros,
    member,
    model_members,
    npy_header,
    png_with_ihdr,
    read_archive,
    seed_images,
    write_zip,
)

from photomodel._limits import MAX_IMAGE_PIXELS

FIGURES = Path(__file__).resolve().parents[2] / "build" / "loader_memory.json"
MARGIN_MB = 256   # the address space a refused input may add
REFUSED_RSS_MB = 32  # the peak RSS it may add

_CODE = """
import json, re, resource, sys, warnings
from pathlib import Path
from photomodel.errors import InputError
from photomodel.{module} import {loader} as load

def status_mb(key):
    text = Path("/proc/self/status").read_text()
    return int(re.search(rf"^{{key}}:\\s+(\\d+) kB", text, re.M).group(1)) / 1024

def maxrss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024

warnings.simplefilter("ignore")
load({warm!r})
try:  # reset the peak (VmHWM) to the present RSS: the imports' peak is not the load's
    Path("/proc/self/clear_refs").write_text("5")
    reset = True
except OSError:
    reset = False
before, maxrss_before = status_mb("VmRSS"), maxrss_mb()
_, hard = resource.getrlimit(resource.RLIMIT_AS)
limit = status_mb("VmSize") + {margin}
resource.setrlimit(resource.RLIMIT_AS, (int(limit * 2**20), hard))
try:
    load({path!r})
    outcome = "loaded"
except InputError as exc:
    outcome = "InputError: " + exc.problem
except MemoryError:
    outcome = "MemoryError"
peak = status_mb("VmHWM") if reset else maxrss_mb()
print(json.dumps({{"rss_before_mb": round(before, 1), "peak_rss_mb": round(peak, 1),
                  "ru_maxrss_before_mb": round(maxrss_before, 1),
                  "ru_maxrss_after_mb": round(maxrss_mb(), 1),
                  "address_space_limit_mb": round(limit), "outcome": outcome}}))
"""


def _measure(module: str, loader: str, warm: Path, path: Path, margin_mb: int = MARGIN_MB
             ) -> dict[str, Any]:
    import subprocess
    import sys

    code = _CODE.format(module=module, loader=loader, warm=str(warm), path=str(path),
                        margin=margin_mb)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stderr == "", done.stderr  # nothing printed on stderr
    figures = json.loads(done.stdout.strip().splitlines()[-1])
    figures["file_bytes"] = path.stat().st_size
    figures["peak_added_mb"] = round(figures["peak_rss_mb"] - figures["rss_before_mb"], 1)
    return figures


def _record(name: str, figures: dict[str, Any]) -> None:
    FIGURES.parent.mkdir(parents=True, exist_ok=True)
    try:
        data = json.loads(FIGURES.read_text())
    except (OSError, ValueError):
        data = {}
    data[name] = figures
    FIGURES.write_text(json.dumps(data, indent=2) + "\n")


def _png_of_zeros(width: int, height: int) -> bytes:
    """A valid PNG of ``width`` x ``height`` black pixels, built without compressing them."""
    n = (1 + 3 * width) * height
    idat = b"\x78\xda" + deflate_zeros(n) + struct.pack(">I", ((n % 65521) << 16) | 1)
    return png_with_ihdr(width, height, idat=idat)


@pytest.fixture(scope="module")
def warm_image(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("warm") / "warm.png"
    path.write_bytes(seed_images()["img.png"])
    return path


@pytest.mark.parametrize("name, data", [
    ("png_header_60000x60000", png_with_ihdr(60000, 60000)),
    ("bmp_header_60000x60000", bmp_with_header(60000, 60000)),
    ("png_header_49MP_no_data", png_with_ihdr(7000, 7000)),
])
def test_a_refused_image_costs_no_memory(tmp_path: Path, warm_image: Path, name: str,
                                         data: bytes) -> None:
    path = tmp_path / f"{name}.png"
    path.write_bytes(data)
    figures = _measure("image", "read_color_image", warm_image, path)
    _record(f"image: {name}", figures)
    assert figures["outcome"].startswith("InputError"), figures
    assert figures["peak_added_mb"] < REFUSED_RSS_MB, figures


def test_the_largest_image_read_costs_its_pixels(tmp_path: Path, warm_image: Path) -> None:
    """A 143 kB PNG of 49 MP (all black) is read: 147 MB of pixels, held about twice at the
    peak (OpenCV's decoding buffer and the result)."""
    side = 7000
    assert side * side <= MAX_IMAGE_PIXELS
    path = tmp_path / "black49mp.png"
    path.write_bytes(_png_of_zeros(side, side))
    figures = _measure("image", "read_color_image", warm_image, path, margin_mb=1024)
    _record("image: png_49MP_black (accepted)", figures)
    assert figures["outcome"] == "loaded", figures
    assert figures["peak_added_mb"] < 2.2 * 3 * side * side / 2**20, figures


@pytest.fixture(scope="module")
def model_parts(model_seed) -> tuple[Path, dict, dict]:
    data, arrays, meta = model_seed
    return data, arrays, meta


def test_a_6_gb_zip_bomb_costs_no_memory(tmp_path: Path, model_parts) -> None:
    data, arrays, meta = model_parts
    warm = tmp_path / "warm.model"
    warm.write_bytes(data)
    path = tmp_path / "bomb.model"
    path.write_bytes(bomb_archive(arrays, meta, 6_000_000_000))
    assert path.stat().st_size < 6_000_000
    figures = _measure("model", "load_model", warm, path)
    _record("model: zip bomb 6 GB (5.9 MB file)", figures)
    assert "unpacks to 6000 MB" in figures["outcome"], figures
    assert figures["peak_added_mb"] < REFUSED_RSS_MB, figures


def test_archives_that_lie_about_their_sizes(tmp_path: Path, model_parts) -> None:
    data, arrays, meta = model_parts
    warm = tmp_path / "warm.model"
    warm.write_bytes(data)
    base = model_members(arrays, meta, skip=("mask",))
    cases = {
        # an array header for 10^12 bytes in a member that declares and holds 100
        "npy header 1e12 bytes": [*base, member("mask.npy", npy_header((10**6, 10**6))
                                                + bytes(100))],
        # a member that declares 1 kB but whose deflate stream unpacks to 6 GB
        "directory says 1 kB, data 6 GB": [*base, _understated(6_000_000_000, 1000)],
    }
    for name, members in cases.items():
        path = tmp_path / "lie.model"
        path.write_bytes(write_zip(members))
        figures = _measure("model", "load_model", warm, path)
        _record(f"model: {name}", figures)
        assert figures["outcome"].startswith("InputError"), (name, figures)
        assert figures["peak_added_mb"] < REFUSED_RSS_MB, (name, figures)


def _understated(n_bytes: int, declared: int):
    from fuzz_helpers import Member

    header = npy_header((n_bytes,))
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    stored = c.compress(header) + c.flush(zlib.Z_FULL_FLUSH) + deflate_zeros(n_bytes)
    return Member("mask.npy", stored, 8, 0, declared)


def test_the_fuzz_seed_model_is_what_the_memory_tests_start_from(model_parts) -> None:
    arrays, meta = read_archive(model_parts[0])
    assert set(arrays) == {"points_in_mm", "hsv_in", "points_out_mm", "outline_mm",
                           "photo_bgr", "mask", "crop_origin_px"}
    assert meta["format"] == "photomodel"
