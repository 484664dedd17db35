"""``/locate`` and ``/identify`` with the views as raw pixels or ``.npy`` (multipart parts or
one octet-stream body): the same pose as the PNG upload of the same pixels, and a one-line
400 naming the field for every malformed upload."""

from __future__ import annotations

import io

import cv2
import httpx
import numpy as np
import pytest

TIMEOUT_S = 300.0
SEED = "7"


def _pair(cell_data) -> tuple[np.ndarray, np.ndarray, dict[str, bytes]]:
    scene = cell_data.scene_of("No.3")
    pngs = {name: (scene / f"{name}.png").read_bytes() for name in ("right", "left")}
    right, left = (cv2.imdecode(np.frombuffer(pngs[n], np.uint8), cv2.IMREAD_COLOR)
                   for n in ("right", "left"))
    return right, left, pngs


def _npy(array: np.ndarray, allow_pickle: bool = False) -> bytes:
    buf = io.BytesIO()
    np.save(buf, array, allow_pickle=allow_pickle)
    return buf.getvalue()


def _size(image: np.ndarray) -> dict[str, str]:
    return {"width": str(image.shape[1]), "height": str(image.shape[0])}


def _post_png(url: str, route: str, pngs: dict[str, bytes], **fields: str) -> httpx.Response:
    files = {n: (f"{n}.png", pngs[n], "image/png") for n in ("right", "left")}
    return httpx.post(f"{url}/{route}", data={"seed": SEED, **fields}, files=files,
                      timeout=TIMEOUT_S)


def _post_parts(url: str, route: str, parts: dict[str, tuple[str, bytes, str]],
                **fields: str) -> httpx.Response:
    return httpx.post(f"{url}/{route}", data={"seed": SEED, **fields}, files=parts,
                      timeout=TIMEOUT_S)


def _post_body(url: str, route: str, body: bytes, **query: str) -> httpx.Response:
    return httpx.post(f"{url}/{route}", params={"seed": SEED, **query}, content=body,
                      headers={"Content-Type": "application/octet-stream"}, timeout=TIMEOUT_S)


def _same_pose(a: dict, b: dict) -> None:
    assert a["found"] == b["found"]
    np.testing.assert_allclose(a["position_mm"], b["position_mm"], atol=1e-6)
    assert a["theta_deg"] == pytest.approx(b["theta_deg"], abs=1e-6)


def test_raw_and_npy_give_the_png_pose(service, cell_data) -> None:
    right, left, pngs = _pair(cell_data)
    url, model = service.url, {"model": "No.3"}
    png = _post_png(url, "locate", pngs, **model)
    assert png.status_code == 200, png.text
    raw_parts = {n: (n, im.tobytes(), "application/octet-stream")
                 for n, im in (("right", right), ("left", left))}
    rgb_parts = {n: (n, im[..., ::-1].tobytes(), "application/octet-stream")
                 for n, im in (("right", right), ("left", left))}
    npy_parts = {n: (f"{n}.npy", _npy(im), "application/x-npy")
                 for n, im in (("right", right), ("left", left))}
    mixed = {"right": npy_parts["right"], "left": ("left.png", pngs["left"], "image/png")}
    # PNG files sent as application/octet-stream (what many clients do) stay image files
    png_as_octets = {n: (n, pngs[n], "application/octet-stream") for n in ("right", "left")}
    answers = [
        _post_parts(url, "locate", png_as_octets, **model),
        _post_parts(url, "locate", raw_parts, **model, **_size(right)),
        _post_parts(url, "locate", rgb_parts, **model, **_size(right), pixel_format="rgb8"),
        _post_parts(url, "locate", npy_parts, **model),
        _post_parts(url, "locate", mixed, **model),
        _post_body(url, "locate", right.tobytes() + left.tobytes(), **model, **_size(right)),
        _post_body(url, "locate", right[..., ::-1].tobytes() + left[..., ::-1].tobytes(),
                   **model, **_size(right), pixel_format="RGB8"),
    ]
    for answer in answers:
        assert answer.status_code == 200, answer.text
        _same_pose(answer.json(), png.json())
    # the pair is kept for the overlay, as an upload's
    overlay = httpx.get(f"{url}/results/{answers[-1].json()['id']}/overlay.png")
    assert overlay.status_code == 200 and overlay.content[:4] == b"\x89PNG"


def test_identify_raw_gives_the_png_answer(service, cell_data) -> None:
    right, left, pngs = _pair(cell_data)
    png = _post_png(service.url, "identify", pngs)
    raw = _post_body(service.url, "identify", right.tobytes() + left.tobytes(), **_size(right))
    assert png.status_code == 200 and raw.status_code == 200, raw.text
    a, b = png.json(), raw.json()
    assert a["found"] and a["model"] == b["model"] == "No.3"
    _same_pose(a, b)


def test_mono8_is_expanded(service, cell_data) -> None:
    right, left, _ = _pair(cell_data)
    grey = [cv2.cvtColor(im, cv2.COLOR_BGR2GRAY) for im in (right, left)]
    answer = _post_body(service.url, "locate", grey[0].tobytes() + grey[1].tobytes(),
                        model="No.3", **_size(right), pixel_format="mono8")
    assert answer.status_code == 200, answer.text
    parts = {n: (f"{n}.npy", _npy(g), "application/octet-stream")   # named .npy: an array
             for n, g in zip(("right", "left"), grey, strict=True)}
    npy = _post_parts(service.url, "locate", parts, model="No.3")
    assert npy.status_code == 200, npy.text
    _same_pose(answer.json(), npy.json())


def _bad_cases(right: np.ndarray, left: np.ndarray):
    h, w = right.shape[:2]
    size = {"width": str(w), "height": str(h)}
    body = right.tobytes() + left.tobytes()
    raw = {n: (n, im.tobytes(), "application/octet-stream")
           for n, im in (("right", right), ("left", left))}
    small = right[: h // 2, : w // 2]
    return [
        ("body short", "body", dict(body=body[:-1], query={"model": "No.3", **size})),
        ("body no width", "width", dict(body=body, query={"model": "No.3", "height": str(h)})),
        ("body bad width", "width", dict(body=body, query={"model": "No.3", "width": "-3",
                                                           "height": str(h)})),
        ("body format", "pixel_format", dict(body=body, query={"model": "No.3", **size,
                                                               "pixel_format": "yuv422"})),
        ("body no model", "model", dict(body=body, query=size)),
        ("body wrong size", "right", dict(
            body=small.tobytes() + small.tobytes(),
            query={"model": "No.3", "width": str(w // 2), "height": str(h // 2)})),
        ("part short", "left", dict(parts={"right": raw["right"],
                                           "left": ("left", body[:10], RAW)},
                                    fields={"model": "No.3", **size})),
        ("part format", "pixel_format", dict(parts=raw, fields={"model": "No.3", **size,
                                                                "pixel_format": "bgr16"})),
        ("part no height", "height", dict(parts=raw, fields={"model": "No.3",
                                                             "width": str(w)})),
        ("npy dtype", "right", dict(parts={"right": ("r.npy", _npy(right.astype(np.uint16)),
                                                     NPY), "left": raw["left"]},
                                    fields={"model": "No.3", **size})),
        ("npy pickle", "left", dict(parts={"right": raw["right"], "left": (
            "l.npy", _npy(np.array([{"a": 1}], dtype=object), allow_pickle=True), NPY)},
            fields={"model": "No.3", **size})),
        ("npy garbage", "right", dict(parts={"right": ("r.npy", b"not an array", NPY),
                                             "left": raw["left"]},
                                      fields={"model": "No.3", **size})),
        ("npy shape", "left", dict(parts={"right": raw["right"],
                                          "left": ("l.npy", _npy(np.zeros((4, 4, 4),
                                                                          np.uint8)), NPY)},
                                   fields={"model": "No.3", **size})),
        ("npy wrong size", "right", dict(parts={"right": ("r.npy", _npy(small), NPY),
                                                "left": ("l.npy", _npy(left), NPY)},
                                         fields={"model": "No.3"})),
    ]


RAW, NPY = "application/octet-stream", "application/x-npy"


def test_bad_raw_uploads_are_400_naming_the_field(service, cell_data) -> None:
    right, left, _ = _pair(cell_data)
    for label, field, case in _bad_cases(right, left):
        for route in ("locate", "identify"):
            if "body" in case:
                query = dict(case["query"])
                if route == "identify":
                    if field == "model":
                        continue
                    query.pop("model", None)
                answer = _post_body(service.url, route, case["body"], **query)
            else:
                fields = {k: v for k, v in case["fields"].items()
                          if route == "locate" or k != "model"}
                answer = _post_parts(service.url, route, case["parts"], **fields)
            assert answer.status_code == 400, (label, route, answer.text)
            error = answer.json()["error"]
            assert error.startswith(f"{field}: ") and "\n" not in error, (label, error)
            assert "Traceback" not in answer.text
    assert httpx.get(f"{service.url}/health").json()["status"] == "ok"


def test_raw_body_over_the_upload_limit_is_413(service) -> None:
    limit = service.cell.config.max_upload_bytes
    answer = _post_body(service.url, "locate", b"\0" * (limit + 1), model="No.3",
                        width="640", height="480")
    assert answer.status_code == 413 and "--max-upload-mb" in answer.json()["error"]
