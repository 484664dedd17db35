"""Registering a garment where it lies through the service: ``POST /models`` with the hand
cameras' views (``right``, ``left``, optional ``empty_right``, ``empty_left``) or
``source=camera``, over real HTTP; and the OPC UA face's ``Register(name)`` with a fake
register callable (asyncua's client over loopback)."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import cv2
import httpx
import numpy as np
import pytest
from numpy.typing import NDArray
from service_helpers import json_error as _error

from photomodel.camera import save_stereo
from photomodel.errors import InputError
from photomodel.geometry import quat_wxyz_from_matrix
from photomodel.service import CellService, ServiceConfig, ServiceThread
from photomodel.sim import catalogue_garment, hand_stereo_rig, parse_conditions, simulate_scene

TIMEOUT_S = 120.0
POSITION_TOL_MM = 2.0
FRAME_S = 1_700_000_000.5


@dataclass(frozen=True)
class Views:
    """PNG bytes of a registration shot of No.5 (with its empty pair), another shot of it,
    and the true silhouette centroid (camera 1, mm) in each."""

    pngs: dict[str, bytes]
    test_pngs: dict[str, bytes]
    centroid_mm: NDArray[np.float64]
    test_centroid_mm: NDArray[np.float64]


def _png(image: NDArray[np.uint8]) -> bytes:
    ok, data = cv2.imencode(".png", image)
    assert ok
    return data.tobytes()


def _centroid(T_cam1_garment: NDArray[np.float64]) -> NDArray[np.float64]:
    """No.5's silhouette centroid in camera 1 (mm), from the simulator's texture."""
    texture = catalogue_garment("No.5").texture
    v, u = np.nonzero(texture.alpha > 0.5)
    xy = texture.mm_from_px(np.column_stack([u, v]).astype(np.float64)).mean(axis=0)
    return T_cam1_garment[:3, :3] @ np.array([xy[0], xy[1], 0.0]) + T_cam1_garment[:3, 3]


@pytest.fixture(scope="module")
def views() -> Views:
    rig = hand_stereo_rig()
    garment = catalogue_garment("No.5")
    shot = simulate_scene(garment, rig, parse_conditions("paper"), 1,
                          placement=(40.0, -30.0, 0.0), empty=True)
    test = simulate_scene(garment, rig, parse_conditions("paper"), 11)
    assert shot.empty_bgr is not None and shot.T_cam1_model is not None
    assert test.T_cam1_model is not None
    pngs = {"right": _png(shot.right_bgr), "left": _png(shot.left_bgr),
            "empty_right": _png(shot.empty_bgr[0]), "empty_left": _png(shot.empty_bgr[1])}
    return Views(pngs, {"right": _png(test.right_bgr), "left": _png(test.left_bgr)},
                 _centroid(shot.T_cam1_model), _centroid(test.T_cam1_model))


@pytest.fixture(scope="module")
def service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ServiceThread]:
    """A warmed service over an empty library, with no model station camera and no camera
    source."""
    root = tmp_path_factory.mktemp("register_in_place")
    save_stereo(root / "stereo.yaml", hand_stereo_rig())
    cell = CellService(ServiceConfig(stereo=root / "stereo.yaml", models=root / "library"))
    with ServiceThread(cell) as running:
        running.wait_ready()
        yield running


def _files(pngs: dict[str, bytes], *names: str) -> dict[str, tuple[str, bytes, str]]:
    return {n: (f"{n}.png", pngs[n], "image/png") for n in names}




def _post(url: str, data: dict[str, str], files: dict[str, Any] | None = None
          ) -> httpx.Response:
    """``POST /models`` as multipart (fields alone as parts without a file name)."""
    if not files:
        return httpx.post(f"{url}/models", files={k: (None, v) for k, v in data.items()},
                          timeout=TIMEOUT_S)
    return httpx.post(f"{url}/models", data=data, files=files, timeout=TIMEOUT_S)


def test_register_in_place_then_locate(service: ServiceThread, views: Views) -> None:
    url = service.url
    created = _post(url, {"name": "skirt"}, _files(views.pngs, "right", "left"))
    assert created.status_code == 201, created.text
    answer = created.json()
    assert answer["name"] == "skirt" and answer["preview"] == "models/skirt/preview.png"
    assert {"size_mm", "area_mm2", "n_in", "n_out"} <= set(answer)
    assert answer["in_place"]["empty_pair"] is False
    assert answer["in_place"]["mm_per_px"] == pytest.approx(0.86, abs=0.02)
    T = np.asarray(answer["T_cam1_model"])
    np.testing.assert_allclose(answer["position_mm"], T[:3, 3])
    np.testing.assert_allclose(answer["quat_wxyz"], quat_wxyz_from_matrix(T[:3, :3]),
                               atol=1e-9)
    error_mm = np.linalg.norm(np.asarray(answer["position_mm"]) - views.centroid_mm)
    assert error_mm < POSITION_TOL_MM, answer["position_mm"]
    listed = httpx.get(f"{url}/models").json()
    assert [m["name"] for m in listed] == ["skirt"]
    assert (service.cell.library.root / "skirt.npz").is_file()
    # the next request uses it: the garment moved, the model's origin went with it
    located = httpx.post(f"{url}/locate", data={"model": "skirt", "seed": "0"},
                         files=_files(views.test_pngs, "right", "left"), timeout=TIMEOUT_S)
    assert located.status_code == 200, located.text
    result = located.json()
    assert result["found"], result
    assert np.linalg.norm(np.asarray(result["position_mm"]) - views.test_centroid_mm) \
        < POSITION_TOL_MM
    # the same name again: 409, unless replacing (here against the empty pair)
    _error(_post(url, {"name": "skirt"}, _files(views.pngs, "right", "left")), 409, "skirt",
           "replace")
    again = _post(url, {"name": "skirt", "replace": "true"},
                  _files(views.pngs, "right", "left", "empty_right", "empty_left"))
    assert again.status_code == 201, again.text
    assert again.json()["in_place"]["empty_pair"] is True
    assert np.linalg.norm(np.asarray(again.json()["position_mm"]) - views.centroid_mm) \
        < POSITION_TOL_MM
    assert [m["name"] for m in httpx.get(f"{url}/models").json()] == ["skirt"]


def test_one_view_alone_is_refused(service: ServiceThread, views: Views) -> None:
    _error(_post(service.url, {"name": "half"}, _files(views.pngs, "right")), 400, "left")
    _error(_post(service.url, {"name": "half"}, _files(views.pngs, "left")), 400, "right")
    _error(_post(service.url, {"name": "half"},
                 _files(views.pngs, "right", "left", "empty_right")), 400, "empty_left",
           "both views")
    assert "half" not in [m["name"] for m in httpx.get(f"{service.url}/models").json()]


def test_garment_in_the_empty_pair_is_refused(service: ServiceThread, views: Views) -> None:
    pngs = dict(views.pngs, empty_right=views.pngs["right"], empty_left=views.pngs["left"])
    _error(_post(service.url, {"name": "ghost"},
                 _files(pngs, "right", "left", "empty_right", "empty_left")), 400,
           "is the garment in the empty pair too?")


def test_source_camera_without_a_camera_source(service: ServiceThread) -> None:
    _error(_post(service.url, {"name": "cam", "source": "camera"}, {}), 409,
           "no camera source")
    _error(_post(service.url, {"name": "cam", "source": "usb"}, {}), 400, "source", "camera")
    assert "cam" not in [m["name"] for m in httpx.get(f"{service.url}/models").json()]


# --- OPC UA Register --------------------------------------------------------------------------


class FakeRegister:
    """``register(name)`` as the service's ``register_from_camera`` answers (a ``/models``
    summary plus where the garment lies and the frame's time); ``bad`` is refused as an
    input error."""

    def __init__(self) -> None:
        self.calls: list[str] = []
        self.lock = threading.Lock()

    def __call__(self, name: str) -> dict[str, Any]:
        with self.lock:
            self.calls.append(name)
        if name == "bad":
            raise InputError("right", "the garment is cut by camera 1's image border")
        return {"name": name, "size_mm": [200.0, 180.0], "area_mm2": 25000.0,
                "preview": f"models/{name}/preview.png", "in_place": {"mm_per_px": 0.86},
                "T_cam1_model": None, "position_mm": [12.5, -20.0, 690.0],
                "quat_wxyz": [1.0, 0.0, 0.0, 0.0], "id": f"reg-{len(self.calls)}",
                "frame_t_s": FRAME_S}


@pytest.fixture(scope="module")
def register() -> FakeRegister:
    return FakeRegister()


@pytest.fixture(scope="module")
def face(register: FakeRegister) -> Iterator[Any]:
    pytest.importorskip("asyncua")
    from photomodel.service._opcua import OpcUaFace, OpcUaThread

    def locate(model: str) -> dict[str, Any]:
        raise AssertionError("not called")

    def identify() -> dict[str, Any]:
        raise AssertionError("not called")

    face = OpcUaFace(locate, identify, register=register,
                     endpoint="opc.tcp://127.0.0.1:0/photomodel/")
    with OpcUaThread(face) as running:
        yield running


def _session(url: str, body: Any) -> Any:
    """``await body(call, values)`` in a fresh client session: ``call(method, *args)`` on
    PhotomodelVision, ``values(names)`` reads its variables."""
    from asyncua import Client, ua

    from photomodel.service._opcua import NAMESPACE

    async def main() -> Any:
        async with Client(url, timeout=20) as client:
            ns = await client.get_namespace_index(NAMESPACE)
            vision = client.get_node(ua.NodeId("PhotomodelVision", ns))

            async def call(method: str, *args: Any) -> Any:
                return await vision.call_method(
                    ua.NodeId(f"PhotomodelVision.{method}", ns), *args)

            async def values(names: list[str]) -> dict[str, Any]:
                nodes = [client.get_node(ua.NodeId(f"PhotomodelVision.{n}", ns))
                         for n in names]
                return dict(zip(names, await client.read_values(nodes), strict=True))

            return await body(call, values)
    return asyncio.run(main())


RESULT = ["Found", "Model", "PositionMm", "QuatWxyz", "ResultId", "Timestamp", "State",
          "ErrorText", "LastCallText"]


def test_opcua_register_answers_and_publishes(face: Any, register: FakeRegister) -> None:
    from datetime import UTC, datetime

    async def body(call: Any, values: Any) -> tuple[Any, dict[str, Any]]:
        return await call("Register", "shirt"), await values(RESULT)

    outputs, v = _session(face.endpoint_url, body)
    assert register.calls[-1] == "shirt"
    assert outputs == [True, "shirt", f"reg-{len(register.calls)}"]
    assert v["Found"] is True and v["Model"] == "shirt" and v["ResultId"] == outputs[2]
    assert v["PositionMm"] == [12.5, -20.0, 690.0] and v["QuatWxyz"] == [1.0, 0.0, 0.0, 0.0]
    assert v["Timestamp"] == datetime.fromtimestamp(FRAME_S, UTC)
    assert (v["State"], v["ErrorText"], v["LastCallText"]) == ("Ready", "", "")


def test_opcua_register_failure_is_bad_with_its_text(face: Any, register: FakeRegister) -> None:
    from asyncua import ua

    async def body(call: Any, values: Any) -> tuple[str, dict[str, Any], Any]:
        with pytest.raises(ua.UaStatusCodeError) as exc:
            await call("Register", "bad")
        code = ua.status_codes.get_name_and_doc(exc.value.code)[0]
        after_bad = await values(RESULT)
        after_good = await call("Register", "next")       # Error -> Busy -> Ready
        return code, after_bad, (after_good, await values(["State", "ErrorText"]))

    code, v, (good, state) = _session(face.endpoint_url, body)
    text = "right: the garment is cut by camera 1's image border"
    assert code == "BadInvalidArgument"
    assert (v["State"], v["ErrorText"], v["LastCallText"]) == ("Error", text, text)
    assert v["Found"] is False and v["Model"] == "" and v["ResultId"] == ""
    assert "bad" in register.calls
    assert good[:2] == [True, "next"] and state == {"State": "Ready", "ErrorText": ""}


def test_opcua_register_needs_a_string_name(face: Any, register: FakeRegister) -> None:
    from asyncua import ua

    async def body(call: Any, values: Any) -> list[str]:
        codes = []
        for args in ((), (ua.Variant(5, ua.VariantType.Int32),)):
            with pytest.raises(ua.UaStatusCodeError) as exc:
                await call("Register", *args)
            codes.append(ua.status_codes.get_name_and_doc(exc.value.code)[0])
        return codes

    before = len(register.calls)
    assert _session(face.endpoint_url, body) == ["BadArgumentsMissing", "BadInvalidArgument"]
    assert len(register.calls) == before              # refused before reaching the cell


def test_opcua_face_without_register_has_no_register_method() -> None:
    """A face made without ``register`` offers no Register method."""
    pytest.importorskip("asyncua")
    from asyncua import ua

    from photomodel.service._opcua import OpcUaFace, OpcUaThread

    plain = OpcUaFace(lambda model: {}, lambda: {},
                      endpoint="opc.tcp://127.0.0.1:0/photomodel/")

    async def body(call: Any, values: Any) -> str:
        with pytest.raises(ua.UaStatusCodeError) as exc:
            await call("Register", "shirt")
        return ua.status_codes.get_name_and_doc(exc.value.code)[0]

    with OpcUaThread(plain) as running:
        code = _session(running.endpoint_url, body)
    assert code in ("BadMethodInvalid", "BadNodeIdUnknown", "BadNodeIdInvalid"), code


def test_a_model_of_unknown_scale_is_stored_at_a_confirmed_scale(service: ServiceThread
                                                                 ) -> None:
    import warnings

    from photomodel.model import build_unknown_scale, load_model, scale_known
    from photomodel.sim import catalogue_garment, model_station_camera, render_model_photos

    photo, _ = render_model_photos(catalogue_garment("No.2"), model_station_camera(), rng=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nominal = build_unknown_scale(photo, name="phone").model
    service.cell.adopt(nominal)
    url = service.url
    scale_url = f"{url}/models/phone/scale"
    _error(httpx.post(scale_url, files={"factor": (None, "100")}, timeout=TIMEOUT_S), 400,
           "factor")
    _error(httpx.post(scale_url, files={"result": (None, "nosuchid")}, timeout=TIMEOUT_S),
           404, "nosuchid")
    _error(httpx.post(f"{url}/models/nope/scale", files={"factor": (None, "0.5")},
                      timeout=TIMEOUT_S), 404, "nope")
    done = httpx.post(scale_url, files={"factor": (None, "0.5657")}, timeout=TIMEOUT_S)
    assert done.status_code == 200, done.text
    assert done.json()["scale"] == pytest.approx(0.5657)
    stored = load_model(service.cell.library.root / "phone.npz")
    assert scale_known(stored) and stored.size_mm[1] == pytest.approx(200, abs=5)
    _error(httpx.post(scale_url, files={"factor": (None, "0.5")}, timeout=TIMEOUT_S), 400,
           "known scale")
