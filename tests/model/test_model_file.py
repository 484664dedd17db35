"""The model loader on archives that are damaged, malformed or implausible (issue 40): each
is refused with one InputError naming the file and what is wrong, before ``locate`` could
trip over it."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from photomodel.errors import InputError
from photomodel.model import load_model, save_model


@pytest.fixture(scope="module")
def saved(plain_case, tmp_path_factory: pytest.TempPathFactory
          ) -> tuple[Path, dict[str, np.ndarray], dict[str, Any]]:
    """The plain garment's model file, its arrays and its metadata."""
    path = save_model(plain_case.built.model, tmp_path_factory.mktemp("model") / "m.model")
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files if k != "meta"}
        meta = json.loads(str(z["meta"]))
    return path, arrays, meta


def _variant(tmp_path: Path, saved, name: str = "variant.model", drop: tuple[str, ...] = (),
             meta: dict[str, Any] | None = None, **arrays: Any) -> Path:
    _, base_arrays, base_meta = saved
    out = {k: v for k, v in {**base_arrays, **arrays}.items() if k not in drop}
    m = {k: v for k, v in {**base_meta, **(meta or {})}.items() if v is not _DROP}
    path = tmp_path / name
    np.savez_compressed(path.open("wb"), meta=np.array(json.dumps(m)), **out)
    return path


_DROP = object()


def _refused(path: Path) -> str:
    with pytest.raises(InputError) as info:
        load_model(path)
    message = str(info.value)
    assert info.value.source == str(path) and message.startswith(str(path))
    assert "\n" not in message
    return message.split(": ", 1)[1]


def test_the_model_as_saved_loads(saved) -> None:
    path, arrays, _ = saved
    model = load_model(path)
    np.testing.assert_array_equal(model.mask, arrays["mask"])
    assert model.n_in == len(arrays["points_in_mm"])


def test_arrays_in_fortran_order_load_in_c_order(tmp_path: Path, saved) -> None:
    path = _variant(tmp_path, saved, **{k: np.asfortranarray(v) for k, v in saved[1].items()})
    model = load_model(path)
    assert model.mask.flags.c_contiguous and model.photo_bgr.flags.c_contiguous
    np.testing.assert_array_equal(model.photo_bgr, saved[1]["photo_bgr"])


def test_a_mask_stored_as_booleans_loads(tmp_path: Path, saved) -> None:
    path = _variant(tmp_path, saved, mask=saved[1]["mask"].astype(bool))
    assert load_model(path).mask.any()


# --- the format version and metadata -------------------------------------------------------


@pytest.mark.parametrize("version", [[1], None, {"a": 1}, float("inf"), "1", True, 1.0])
def test_a_version_that_is_not_a_whole_number(tmp_path: Path, saved, version: Any) -> None:
    assert "version" in _refused(_variant(tmp_path, saved, meta={"version": version}))


@pytest.mark.parametrize("version", [0, -1, 2, 10**30])
def test_an_unsupported_version(tmp_path: Path, saved, version: int) -> None:
    assert "not supported" in _refused(_variant(tmp_path, saved, meta={"version": version}))


@pytest.mark.parametrize("change", [
    {"camera_K": _DROP}, {"camera_K": "K"}, {"camera_K": [[1e12, 0, 320], [0, 1e12, 240],
                                                           [0, 0, 1]]},
    {"camera_dist": [0.1, 0.2]}, {"distance_mm": float("inf")}, {"distance_mm": "400"},
    {"distance_mm": True}, {"centroid_in_camera_mm": [1, 2]},
    {"centroid_in_camera_mm": [float("nan"), 0, 400]}, {"photo_size_px": [640]},
    {"photo_size_px": [-640, 480]}, {"name": ["a"]}, {"name": "two\nlines"}, {"name": ""},
])
def test_metadata_the_default_method_uses(tmp_path: Path, saved, change: dict) -> None:
    _refused(_variant(tmp_path, saved, meta=change))


def test_metadata_that_is_not_an_object(tmp_path: Path, saved) -> None:
    path = tmp_path / "list.model"
    np.savez(path.open("wb"), meta=np.array("[1, 2]"), **saved[1])
    assert "not a photomodel" in _refused(path)


def test_metadata_nested_beyond_recursion(tmp_path: Path, saved) -> None:
    path = tmp_path / "deep.model"
    np.savez(path.open("wb"), meta=np.array("[" * 100_000 + "]" * 100_000), **saved[1])
    assert "not JSON" in _refused(path)


# --- the arrays ----------------------------------------------------------------------------


def _shifted(a: np.ndarray, dx: float) -> np.ndarray:
    b = a.copy()
    b[:, 0] += dx
    return b


def _with_nan(a: np.ndarray) -> np.ndarray:
    b = a.astype(np.float64)
    b[len(b) // 2, 0] = np.nan
    return b


@pytest.mark.parametrize("key, value", [
    ("mask", lambda a: a["mask"][:10]),
    ("mask", lambda a: a["mask"] * 2),
    ("mask", lambda a: a["mask"].astype(np.float64)),
    ("mask", lambda a: np.zeros_like(a["mask"])),
    ("photo_bgr", lambda a: a["photo_bgr"][..., 0]),
    ("photo_bgr", lambda a: a["photo_bgr"].astype(np.float32)),
    ("photo_bgr", lambda a: np.concatenate([a["photo_bgr"], a["photo_bgr"][..., :1]], 2)),
    ("crop_origin_px", lambda a: np.array([1, 2, 3])),
    ("crop_origin_px", lambda a: np.array([1e300, 2.0])),
    ("crop_origin_px", lambda a: np.array([-5, 0])),
    ("crop_origin_px", lambda a: np.array([600, 0])),
    ("points_in_mm", lambda a: a["points_in_mm"][:1]),
    ("points_in_mm", lambda a: _with_nan(a["points_in_mm"])),
    ("points_in_mm", lambda a: _shifted(a["points_in_mm"], 60.0)),
    ("points_in_mm", lambda a: a["points_in_mm"] * 1e6),
    ("points_in_mm", lambda a: a["points_in_mm"] + [0, 0, 1]),
    ("points_in_mm", lambda a: a["points_in_mm"] * [0.2, 0.2, 1]),
    ("hsv_in", lambda a: a["hsv_in"] * 400),
    ("hsv_in", lambda a: a["hsv_in"][:-1]),
    ("points_out_mm", lambda a: np.zeros((0, 3))),
    ("points_out_mm", lambda a: a["points_in_mm"]),
    ("points_out_mm", lambda a: _with_nan(a["points_out_mm"])),
    ("outline_mm", lambda a: a["outline_mm"][:2]),
    ("outline_mm", lambda a: a["outline_mm"] * 1e6),
    ("outline_mm", lambda a: a["outline_mm"] * 0.5),
], ids=["mask-shape", "mask-values", "mask-float", "mask-empty", "photo-2d", "photo-float",
        "photo-4-channels", "crop-3", "crop-float", "crop-negative", "crop-outside",
        "s-in-one-point", "s-in-nan", "s-in-off-mask", "s-in-1e6", "s-in-z", "s-in-shrunk",
        "hsv-range", "hsv-count", "s-out-empty", "s-out-on-mask", "s-out-nan",
        "outline-2-points", "outline-1e6", "outline-half"])
def test_malformed_arrays(tmp_path: Path, saved, key: str, value) -> None:
    problem = _refused(_variant(tmp_path, saved, **{key: value(saved[1])}))
    assert key in problem or "mask" in problem


def test_all_points_scaled_by_a_million(tmp_path: Path, saved) -> None:
    """The issue's model that ``locate --overlay`` crashed on after its search."""
    arrays = saved[1]
    path = _variant(tmp_path, saved, **{k: arrays[k] * 1e6 for k in
                                        ("points_in_mm", "points_out_mm", "outline_mm")})
    assert "2000 mm" in _refused(path)


@pytest.mark.parametrize("key", ["points_in_mm", "mask", "photo_bgr", "crop_origin_px"])
def test_a_missing_array(tmp_path: Path, saved, key: str) -> None:
    assert key in _refused(_variant(tmp_path, saved, drop=(key,)))


def test_an_object_array_is_not_unpickled(tmp_path: Path, saved) -> None:
    path = tmp_path / "pickle.model"
    arrays = {**saved[1], "mask": np.array([1, "a", None], dtype=object)}
    np.savez(path.open("wb"), meta=np.array(json.dumps(saved[2])), **arrays)
    assert "object" in _refused(path)


# --- the archive ---------------------------------------------------------------------------


def test_one_byte_changed_early_in_the_compressed_data(tmp_path: Path, saved) -> None:
    data = bytearray(saved[0].read_bytes())
    data[60] ^= 0xFF
    path = tmp_path / "byte.model"
    path.write_bytes(bytes(data))
    assert "corrupt" in _refused(path) or "damaged" in _refused(path)


def _zip(tmp_path: Path, members: list[tuple[zipfile.ZipInfo | str, bytes]],
         compression: int = zipfile.ZIP_DEFLATED) -> Path:
    path = tmp_path / "archive.model"
    with zipfile.ZipFile(path, "w", compression) as z:
        for info, data in members:
            z.writestr(info, data)
    return path


def _npy(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, array, allow_pickle=False)
    return buf.getvalue()


def _members(saved) -> list[tuple[str, bytes]]:
    _, arrays, meta = saved
    return [("meta.npy", _npy(np.array(json.dumps(meta))))] + [
        (f"{k}.npy", _npy(v)) for k, v in arrays.items()]


def test_a_member_twice(tmp_path: Path, saved) -> None:
    members = _members(saved)
    with pytest.warns(UserWarning):  # zipfile's own, when writing it
        path = _zip(tmp_path, [*members, members[-1]])
    assert "twice" in _refused(path)


def test_an_lzma_member(tmp_path: Path, saved) -> None:
    assert "compression" in _refused(_zip(tmp_path, _members(saved), zipfile.ZIP_LZMA))


def test_many_members(tmp_path: Path, saved) -> None:
    members = _members(saved) + [(f"extra{i}.npy", b"") for i in range(30)]
    assert "members" in _refused(_zip(tmp_path, members))


def test_an_array_header_claiming_more_than_its_member_holds(tmp_path: Path, saved) -> None:
    """An npy header for 10^12 bytes in a member of a few: refused before allocating."""
    members = dict(_members(saved))
    text = "{'descr': '|u1', 'fortran_order': False, 'shape': (1000000, 1000000, 1), }"
    text += " " * (-(len(text) + 11) % 64) + "\n"
    header = b"\x93NUMPY\x01\x00" + len(text).to_bytes(2, "little") + text.encode()
    members["mask.npy"] = header + b"\x00" * 100
    assert "declares" in _refused(_zip(tmp_path, list(members.items())))


@pytest.mark.parametrize("text", [
    "{'descr': '<f8', 'fortran_order': False, 'shP_order': False, 'shP_orrrr@\xa881, 3), }",
    "{'descr': '<f8', 'fortran_order': False, 'shape': " + "(" * 3000 + ")" * 3000 + "}",
    "{'descr': '<f8', 'fortran_order': False, 'shape': (-3, 3), }",
    "{'descr': [('a', '<f8')], 'fortran_order': False, 'shape': (3,), }",
], ids=["token-error", "nested", "negative", "structured"])
def test_a_damaged_array_header(tmp_path: Path, saved, text: str) -> None:
    """Found by the long fuzz run: numpy's header parse raised tokenize.TokenError."""
    members = dict(_members(saved))
    text += " " * (-(len(text) + 11) % 64) + "\n"
    header = b"\x93NUMPY\x01\x00" + len(text).to_bytes(2, "little") + text.encode("latin-1")
    members["points_in_mm.npy"] = header + bytes(72)
    assert "points_in_mm" in _refused(_zip(tmp_path, list(members.items())))


def test_a_directory_declaring_more_than_the_bound(tmp_path: Path, saved) -> None:
    """The central directory says the photo unpacks to 4 GB (zipfile trusts it)."""
    data = bytearray(saved[0].read_bytes())
    at = data.find(b"PK\x01\x02")
    while at >= 0:
        name_length = int.from_bytes(data[at + 28:at + 30], "little")
        name = bytes(data[at + 46:at + 46 + name_length])
        if name == b"photo_bgr.npy":
            data[at + 24:at + 28] = (0xF0000000).to_bytes(4, "little")
        at = data.find(b"PK\x01\x02", at + 4)
    path = tmp_path / "declared.model"
    path.write_bytes(bytes(data))
    assert "MB" in _refused(path)


@pytest.mark.parametrize("content", [b"", b"PK\x05\x06" + bytes(18), b"not a zip" * 10])
def test_not_an_archive(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "x.model"
    path.write_bytes(content)
    _refused(path)
