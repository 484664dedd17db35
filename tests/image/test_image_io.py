"""The image loader: what it reads, and each way a file can be refused before (or by) the
decoder with one InputError naming the file, silently (nothing on stderr)."""

from __future__ import annotations

import os
import struct
import warnings
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest

from photomodel._limits import MAX_IMAGE_PIXELS
from photomodel.errors import InputError, InputWarning
from photomodel.image import _io as image_io
from photomodel.image import decode_color_image, read_color_image, read_grey_image


def _image(seed: int = 0, shape: tuple[int, int] = (48, 64)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return cv2.GaussianBlur(rng.integers(0, 256, (*shape, 3), dtype=np.uint8), (0, 0), 2)


def _encoded(ext: str, image: np.ndarray | None = None, *params: int) -> bytes:
    return cv2.imencode(ext, _image() if image is None else image, list(params))[1].tobytes()


def _chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def _png(width: int, height: int, idat: bytes = zlib.compress(b"\x00" * 10)) -> bytes:
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", idat)
            + _chunk(b"IEND", b""))


def _bmp(width: int, height: int, pixels: bytes = b"\x00" * 10) -> bytes:
    info = struct.pack("<IiiHHIIiiII", 40, width, height, 1, 24, 0, 0, 2835, 2835, 0, 0)
    return b"BM" + struct.pack("<IHHI", 54 + len(pixels), 0, 0, 54) + info + pixels


def _jpeg_sof(width: int, height: int) -> bytes:
    sof = struct.pack(">HBHHB", 11, 8, height, width, 1) + b"\x01\x11\x00"
    return b"\xff\xd8\xff\xc0" + sof + b"\xff\xd9"


def _refused(path: Path, capfd: pytest.CaptureFixture[str]) -> str:
    with pytest.raises(InputError) as info:
        read_color_image(path)
    message = str(info.value)
    assert info.value.source == str(path) and message.startswith(str(path))
    assert "\n" not in message
    assert capfd.readouterr().err == ""  # neither libpng, libjpeg nor OpenCV printed
    return message


# --- what is read --------------------------------------------------------------------------


@pytest.mark.parametrize("ext", [".png", ".bmp"])
def test_lossless_formats_read_exactly(tmp_path: Path, ext: str) -> None:
    image = _image(1)
    path = tmp_path / f"a{ext}"
    path.write_bytes(_encoded(ext, image))
    np.testing.assert_array_equal(read_color_image(path), image)


def test_jpeg_reads_close(tmp_path: Path) -> None:
    image = _image(2)
    path = tmp_path / "a.jpg"
    path.write_bytes(_encoded(".jpg", image, cv2.IMWRITE_JPEG_QUALITY, 95))
    got = read_color_image(path)
    assert got.shape == image.shape and got.dtype == np.uint8
    assert np.abs(got.astype(int) - image).mean() < 3


def test_sixteen_bit_png_is_scaled_exactly(tmp_path: Path) -> None:
    image16 = np.random.default_rng(3).integers(0, 65536, (20, 30, 3), dtype=np.uint16)
    image16[0, :3, 0] = [257 * 7, 65535, 256]  # exact multiples of 257 stay exact
    path = tmp_path / "deep.png"
    path.write_bytes(_encoded(".png", image16))
    got = read_color_image(path)
    np.testing.assert_array_equal(got, (image16 // 257).astype(np.uint8))
    assert list(got[0, :3, 0]) == [7, 255, 0]


def test_alpha_is_dropped(tmp_path: Path) -> None:
    image = _image(4)
    path = tmp_path / "rgba.png"
    path.write_bytes(_encoded(".png", cv2.cvtColor(image, cv2.COLOR_BGR2BGRA)))
    np.testing.assert_array_equal(read_color_image(path), image)


def test_the_file_ending_does_not_matter(tmp_path: Path) -> None:
    path = tmp_path / "photo.jpg"
    path.write_bytes(_encoded(".png"))
    assert read_color_image(path).shape == (48, 64, 3)


# --- refused before decoding ---------------------------------------------------------------


@pytest.mark.parametrize("make", [_png, _bmp, _jpeg_sof], ids=["png", "bmp", "jpeg"])
def test_a_tiny_file_claiming_60000_x_60000_pixels(tmp_path: Path, capfd, make) -> None:
    data = make(60000, 60000)
    assert len(data) <= 80  # the 74-byte PNG, 64-byte BMP
    path = tmp_path / "huge"
    path.write_bytes(data)
    message = _refused(path, capfd)
    assert "60000x60000" in message and "megapixels" in message


def test_the_pixel_bound_is_inclusive(tmp_path: Path, capfd) -> None:
    side = int(np.sqrt(MAX_IMAGE_PIXELS)) + 1
    path = tmp_path / "over.png"
    path.write_bytes(_png(side, side))
    assert "megapixels" in _refused(path, capfd)
    path.write_bytes(_png(side - 1, side - 1))  # within the bound: refused by the decoder
    assert "megapixels" not in _refused(path, capfd)


def test_a_side_longer_than_opencv_remaps(tmp_path: Path, capfd) -> None:
    path = tmp_path / "strip.png"
    path.write_bytes(_png(40000, 10))
    assert "a side" in _refused(path, capfd)


def test_a_file_larger_than_the_bound(tmp_path: Path, capfd, monkeypatch) -> None:
    monkeypatch.setattr(image_io, "MAX_IMAGE_FILE_BYTES", 1000)
    path = tmp_path / "big.png"
    path.write_bytes(_encoded(".png"))
    assert "larger than" in _refused(path, capfd)


@pytest.mark.parametrize("ext", [".png", ".bmp", ".jpg"])
@pytest.mark.parametrize("keep", [0.5, 0.05])
def test_truncated_images(tmp_path: Path, capfd, ext: str, keep: float) -> None:
    data = _encoded(ext, _image(5, (120, 160)))
    path = tmp_path / f"cut{ext}"
    path.write_bytes(data[:int(len(data) * keep)])
    message = _refused(path, capfd)
    assert "truncated" in message or "damaged" in message


def test_png_with_a_failing_crc(tmp_path: Path, capfd) -> None:
    data = bytearray(_encoded(".png"))
    data[-20] ^= 0xFF  # inside the last IDAT
    path = tmp_path / "crc.png"
    path.write_bytes(bytes(data))
    assert "CRC" in _refused(path, capfd)


def test_png_whose_data_does_not_inflate(tmp_path: Path, capfd) -> None:
    """Chunks whole and CRCs right, so libpng itself fails: its complaint becomes the
    message, not a line of its own on stderr."""
    path = tmp_path / "zlib.png"
    path.write_bytes(_png(16, 16, idat=b"\x78\x9c" + b"\xff" * 30))
    message = _refused(path, capfd)
    assert "damaged PNG data" in message and "IDAT" in message


@pytest.mark.parametrize("data", [b"", b"GIF89a" + bytes(40), b"hello world\n" * 10,
                                  b"\x89PNG\r\n\x1a\n", b"BM", b"\xff\xd8\xff"],
                         ids=["empty", "gif", "text", "png-signature", "bm", "jpeg-soi"])
def test_not_an_image(tmp_path: Path, capfd, data: bytes) -> None:
    path = tmp_path / "x.png"
    path.write_bytes(data)
    _refused(path, capfd)


def test_missing_file_and_directory(tmp_path: Path, capfd) -> None:
    assert "not found" in _refused(tmp_path / "nowhere.png", capfd)
    assert "is a directory, not the image file" in _refused(tmp_path, capfd)


def test_greyscale_is_refused(tmp_path: Path, capfd) -> None:
    path = tmp_path / "grey.png"
    path.write_bytes(_encoded(".png", cv2.cvtColor(_image(), cv2.COLOR_BGR2GRAY)))
    assert "greyscale" in _refused(path, capfd)


def test_a_jpeg_of_thousands_of_scans_is_refused(tmp_path: Path, capfd) -> None:
    data = _encoded(".jpg")
    path = tmp_path / "scans.jpg"
    path.write_bytes(data[:-2] + b"\xff\xda\x00\x02" * 1200 + b"\xff\xd9")
    assert "scans" in _refused(path, capfd)


# --- damaged but decodable -----------------------------------------------------------------


def test_damaged_jpeg_data_decodes_with_one_warning(tmp_path: Path, capfd) -> None:
    data = _encoded(".jpg", _image(6, (120, 160)))
    path = tmp_path / "damaged.jpg"
    path.write_bytes(data[:len(data) * 2 // 3] + b"\xff\xd9")  # its last rows are missing
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image = read_color_image(path)
    assert image.shape == (120, 160, 3)
    assert [w.category for w in caught] == [InputWarning]
    assert str(caught[0].message).startswith(str(path))
    assert capfd.readouterr().err == ""


def test_other_output_during_a_decode_still_reaches_stderr(capfd) -> None:
    """Only the decoders' lines are kept back while fd 2 is borrowed."""
    with image_io._stderr_caught() as caught:
        os.write(2, b"libpng warning: iCCP: known incorrect sRGB profile\n")
        os.write(2, b"a line of someone else's\n")
    assert caught == ["iCCP: known incorrect sRGB profile"]
    assert capfd.readouterr().err == "a line of someone else's\n"


# --- grey images (masks) -------------------------------------------------------------------


def test_a_mask_reads_as_grey_levels(tmp_path: Path) -> None:
    mask = np.zeros((30, 40), np.uint8)
    mask[5:20, 10:30] = 255
    path = tmp_path / "mask.png"
    path.write_bytes(_encoded(".png", mask))
    np.testing.assert_array_equal(read_grey_image(path, "mask"), mask)
    path.write_bytes(_encoded(".png", cv2.cvtColor(mask, cv2.COLOR_GRAY2BGR)))
    np.testing.assert_array_equal(read_grey_image(path, "mask"), mask)


def test_a_mask_claiming_60000_x_60000_pixels(tmp_path: Path, capfd) -> None:
    path = tmp_path / "mask.png"
    path.write_bytes(_png(60000, 60000))
    with pytest.raises(InputError, match="60000x60000"):
        read_grey_image(path, "mask")
    with pytest.raises(InputError, match="mask file not found"):
        read_grey_image(tmp_path / "none.png", "mask")
    assert capfd.readouterr().err == ""


def test_bytes_from_a_client_are_checked_alike(capfd) -> None:
    image = _image(7)
    np.testing.assert_array_equal(decode_color_image(_encoded(".png", image), "upload"), image)
    with pytest.raises(InputError) as info:
        decode_color_image(_png(60000, 60000), "right (upload)")
    assert str(info.value).startswith("right (upload): PNG claims 60000x60000")
    with pytest.raises(InputError, match="upload: damaged"):
        decode_color_image(_encoded(".jpg")[:300], "upload")
    assert capfd.readouterr().err == ""


@pytest.mark.parametrize("ext", [".png", ".jpg", ".bmp"])
def test_a_pair_decoded_at_once_equals_one_by_one(ext: str, capfd) -> None:
    right, left = _encoded(ext, _image(8)), _encoded(ext, _image(9))
    pair = image_io.decode_color_images([(right, "right"), (left, "left")])
    np.testing.assert_array_equal(pair[0], decode_color_image(right, "right"))
    np.testing.assert_array_equal(pair[1], decode_color_image(left, "left"))
    assert capfd.readouterr().err == ""


@pytest.mark.parametrize("damaged", [0, 1])
def test_in_a_pair_each_message_names_its_own_file(damaged: int, capfd) -> None:
    """The two views decode in parallel threads; what a decoder says is told to the file it
    is about, whichever of the two it is."""
    good = _encoded(".png", _image(10))
    bad_png = _png(16, 16, idat=b"\x78\x9c" + b"\xff" * 30)
    files = [(good, "right"), (good, "left")]
    files[damaged] = (bad_png, files[damaged][1])
    with pytest.raises(InputError) as info:
        image_io.decode_color_images(files)
    assert info.value.source == files[damaged][1] and "IDAT" in str(info.value)
    jpeg = _encoded(".jpg", _image(6, (120, 160)))
    files = [(_encoded(".jpg", _image(5, (120, 160))), "right"), (jpeg, "left")]
    files[damaged] = (jpeg[:len(jpeg) * 2 // 3] + b"\xff\xd9", files[damaged][1])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        images = image_io.decode_color_images(files)
    assert [im.shape for im in images] == [(120, 160, 3)] * 2
    assert [str(w.message).split(":")[0] for w in caught] == [files[damaged][1]]
    assert capfd.readouterr().err == ""
