"""The OPC UA face (``photomodel.service._opcua``) with asyncua's client over loopback and
fake callables in place of the cell: the methods' answers, the result variables, the state
machine, Bad status codes with their text for refused and failed calls, the server serving
on after them, and the binding rules (loopback by default, credentials otherwise)."""

from __future__ import annotations

import asyncio
import math
import os
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("asyncua")

from asyncua import Client, ua  # noqa: E402

from photomodel.errors import InputError  # noqa: E402
from photomodel.service._cell import Conflict, NotFound, Unavailable  # noqa: E402
from photomodel.service._opcua import (  # noqa: E402
    NAMESPACE,
    OpcUaFace,
    OpcUaThread,
    run_opcua_in_thread,
)
from photomodel.service._source import SourceError  # noqa: E402

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "opcua_client.py"
ENDPOINT = "opc.tcp://127.0.0.1:0/photomodel/"
TOKEN = "s3cret-token-0123456789"
FRAME_S = 1_700_000_000.25
RESULT_VARS = ["Found", "Model", "PositionMm", "QuatWxyz", "ThetaDeg", "Score", "Timestamp",
               "ResultId", "State", "StateNumber", "ErrorText", "LastCallText"]


def _answer(model: str | None, found: bool, rid: str) -> dict[str, Any]:
    """Shaped like the service's /locate and /identify answers."""
    pose = model is not None
    return {"model": model, "found": found,
            "T_cam1_model": None,
            "position_mm": [-49.4, -54.5, 691.9] if pose else None,
            "quat_wxyz": [0.966, 0.0, 0.0, 0.259] if pose else None,
            "theta_deg": 30.05 if pose else None, "fitness": 0.1, "score": 0.911 if pose else 0.12,
            "seconds": 0.02, "id": rid, "frame_t_s": FRAME_S,
            "pose_stamped": {"header": {"frame_id": "cam1", "stamp": FRAME_S + 1.0}}}


class FakeCell:
    """``locate(model)`` and ``identify()`` as the service's trigger methods behave: No.3 is
    found, X is unknown (InputError), Y is NotFound, warming is Unavailable, boom is a bug,
    slow waits for ``release``."""

    def __init__(self) -> None:
        self.release = threading.Event()
        self.started = threading.Event()
        self.calls: list[str] = []
        self.threads: set[str] = set()

    def locate(self, model: str) -> dict[str, Any]:
        self.calls.append(model)
        self.threads.add(threading.current_thread().name)
        if model == "X":
            raise InputError("model", "no model 'X' in the library")
        if model == "Y":
            raise NotFound("model", "no model named 'Y'")
        if model == "warming":
            raise Unavailable("service", "warming up (loading kernels)")
        if model == "camera-down":
            raise SourceError("replay:/data", "no frames: the folder went away")
        if model == "no-source":
            raise Conflict("source", "this service has no camera source")
        if model == "boom":
            raise RuntimeError("a bug")
        if model == "slow":
            self.started.set()
            assert self.release.wait(20)
        return _answer("No.3" if model != "slow" else "slow", True, f"id-{len(self.calls)}")

    def identify(self) -> dict[str, Any]:
        self.calls.append("identify")
        return _answer(None, False, f"id-{len(self.calls)}")


@pytest.fixture(scope="module")
def cell() -> FakeCell:
    return FakeCell()


@pytest.fixture(scope="module")
def face(cell: FakeCell) -> Iterator[OpcUaThread]:
    with OpcUaThread(OpcUaFace(cell.locate, cell.identify, endpoint=ENDPOINT)) as running:
        yield running


class Session:
    """An asyncua client session on the face, with the face's nodes by name."""

    def __init__(self, client: Client, ns: int) -> None:
        self.client = client
        self.ns = ns
        self.vision = client.get_node(ua.NodeId("PhotomodelVision", ns))

    def node(self, name: str) -> Any:
        return self.client.get_node(ua.NodeId(f"PhotomodelVision.{name}", self.ns))

    async def call(self, method: str, *args: Any) -> list[Any]:
        return await self.vision.call_method(ua.NodeId(f"PhotomodelVision.{method}", self.ns),
                                             *args)

    async def raw_call(self, method: str, *variants: ua.Variant) -> ua.CallMethodResult:
        request = ua.CallMethodRequest(
            ObjectId=self.vision.nodeid,
            MethodId=ua.NodeId(f"PhotomodelVision.{method}", self.ns),
            InputArguments=list(variants))
        return (await self.client.uaclient.call([request]))[0]

    async def values(self, names: list[str] = RESULT_VARS) -> dict[str, Any]:
        read = await self.client.read_values([self.node(n) for n in names])
        return dict(zip(names, read, strict=True))


def _run(url: str, body: Any, *, user: str | None = None, password: str | None = None) -> Any:
    """Run ``await body(session)`` in a fresh client session on ``url``."""
    async def main() -> Any:
        client = Client(url, timeout=20)
        if user is not None:
            client.set_user(user)
        if password is not None:
            client.set_password(password)
        async with client:
            return await body(Session(client, await client.get_namespace_index(NAMESPACE)))
    return asyncio.run(main())


def _code(exc: pytest.ExceptionInfo[ua.UaStatusCodeError]) -> str:
    return ua.status_codes.get_name_and_doc(exc.value.code)[0]


def test_locate_answers_and_publishes_the_result(face: OpcUaThread, cell: FakeCell) -> None:
    async def body(s: Session) -> tuple[list[Any], dict[str, Any]]:
        return await s.call("Locate", "No.3"), await s.values()

    outputs, v = _run(face.endpoint_url, body)
    assert outputs == [True, f"id-{len(cell.calls)}"]
    assert v["Found"] is True and v["Model"] == "No.3" and v["ResultId"] == outputs[1]
    assert v["PositionMm"] == [-49.4, -54.5, 691.9]
    assert v["QuatWxyz"] == [0.966, 0.0, 0.0, 0.259]
    assert v["ThetaDeg"] == 30.05 and v["Score"] == 0.911
    # the frame's time, not the answer's (pose_stamped's stamp is 1 s later here)
    assert v["Timestamp"] == datetime.fromtimestamp(FRAME_S, UTC)
    assert (v["State"], v["StateNumber"], v["ErrorText"], v["LastCallText"]) == \
        ("Ready", 6, "", "")
    # the callable ran in the face's worker thread, not on the server's event loop
    assert cell.threads == {n for n in cell.threads if n.startswith("photomodel-opcua_")}


def test_identify_with_nothing_on_the_table(face: OpcUaThread) -> None:
    async def body(s: Session) -> tuple[list[Any], dict[str, Any]]:
        return await s.call("Identify"), await s.values()

    outputs, v = _run(face.endpoint_url, body)
    assert outputs[:2] == [False, ""] and outputs[2].startswith("id-")
    assert v["Found"] is False and v["Model"] == "" and v["ResultId"] == outputs[2]
    assert all(math.isnan(x) for x in v["PositionMm"] + v["QuatWxyz"] + [v["ThetaDeg"]])
    assert v["Score"] == 0.12 and v["State"] == "Ready"


def test_a_failed_call_is_bad_with_its_text_and_enters_error(face: OpcUaThread) -> None:
    async def body(s: Session) -> list[Any]:
        seen = []
        for model, code in [("X", "BadInvalidArgument"), ("Y", "BadNotFound"),
                            ("warming", "BadResourceUnavailable"),
                            ("no-source", "BadInvalidState")]:
            with pytest.raises(ua.UaStatusCodeError) as exc:
                await s.call("Locate", model)
            seen.append((_code(exc), code, await s.values()))
        after = await s.call("Locate", "No.3")         # Error -> Busy -> Ready
        seen.append(await s.values())
        with pytest.raises(ua.UaStatusCodeError):
            await s.call("Locate", "X")
        await s.call("Reset")                            # Error -> Ready, no search
        seen.append(await s.values(["State", "StateNumber", "ErrorText", "LastCallText"]))
        return [seen, after]

    seen, after = _run(face.endpoint_url, body)
    texts = ["model: no model 'X' in the library", "model: no model named 'Y'",
             "service: warming up (loading kernels)",
             "source: this service has no camera source"]
    for (got, expected, v), text in zip(seen[:4], texts, strict=True):
        assert got == expected
        assert (v["State"], v["StateNumber"]) == ("Error", 3)
        assert v["ErrorText"] == v["LastCallText"] == text
        # no stale result to read after a failure
        assert v["Found"] is False and v["ResultId"] == "" and math.isnan(v["Score"])
        assert v["Timestamp"].year == 1601               # OPC UA's null DateTime
    assert after[0] is True
    assert (seen[4]["State"], seen[4]["ErrorText"], seen[4]["Found"]) == ("Ready", "", True)
    assert seen[5] == {"State": "Ready", "StateNumber": 6, "ErrorText": "",
                       "LastCallText": ""}


def test_a_camera_source_down_is_resource_unavailable(face: OpcUaThread) -> None:
    async def body(s: Session) -> tuple[str, dict[str, Any]]:
        with pytest.raises(ua.UaStatusCodeError) as exc:
            await s.call("Locate", "camera-down")
        return _code(exc), await s.values(["State", "ErrorText"])

    code, v = _run(face.endpoint_url, body)
    assert code == "BadResourceUnavailable" and v["State"] == "Error"
    assert v["ErrorText"].startswith("replay:/data: ")


def test_an_internal_error_is_bad_without_a_traceback(face: OpcUaThread) -> None:
    async def body(s: Session) -> tuple[str, dict[str, Any], list[Any]]:
        with pytest.raises(ua.UaStatusCodeError) as exc:
            await s.call("Locate", "boom")
        v = await s.values()
        return _code(exc), v, await s.call("Locate", "No.3")

    code, v, after = _run(face.endpoint_url, body)
    assert code == "BadInternalError" and v["State"] == "Error"
    assert "RuntimeError: a bug" in v["ErrorText"] and "Traceback" not in v["ErrorText"]
    assert after[0] is True                              # the server serves on


def test_wrong_arguments_are_refused_with_their_text(face: OpcUaThread, cell: FakeCell
                                                     ) -> None:
    string = ua.VariantType.String
    cases = [("Locate", [ua.Variant(3, ua.VariantType.Int32)], "BadInvalidArgument",
              "got Int32"),
             ("Locate", [ua.Variant(["No.3"], string)], "BadInvalidArgument",
              "got an array of String"),
             ("Locate", [ua.Variant(None, string)], "BadInvalidArgument", "got null"),
             ("Locate", [], "BadArgumentsMissing", "expected 1 argument(s) (model), got 0"),
             ("Locate", [ua.Variant("No.3"), ua.Variant("No.5")], "BadTooManyArguments",
              "got 2"),
             ("Identify", [ua.Variant("No.3")], "BadTooManyArguments", "got 1"),
             ("Reset", [ua.Variant(1.5)], "BadTooManyArguments", "got 1")]

    async def body(s: Session) -> list[Any]:
        out = []
        for method, args, _, _ in cases:
            result = await s.raw_call(method, *args)
            out.append((result, await s.values(["State", "LastCallText"])))
        out.append(await s.call("Locate", "No.3"))
        return out

    before = len(cell.calls)
    results = _run(face.endpoint_url, body)
    assert len(cell.calls) == before + 1                 # no refused call reached the cell
    for (result, v), (method, _, code, text) in zip(results[:-1], cases, strict=True):
        assert ua.status_codes.get_name_and_doc(result.StatusCode.value)[0] == code
        assert v["State"] == "Ready"                     # refused: the state did not move
        assert v["LastCallText"].startswith(f"{method}: ") and text in v["LastCallText"]
    # a wrong type marks the argument (BadTypeMismatch) and carries the text as its diagnostic
    first = results[0][0]
    assert [s.value for s in first.InputArgumentResults] == [ua.StatusCodes.BadTypeMismatch]
    assert first.InputArgumentDiagnosticInfos[0].AdditionalInfo == results[0][1]["LastCallText"]
    assert results[-1][0] is True                        # the server serves on


def test_a_call_while_busy_is_refused_and_the_job_finishes(face: OpcUaThread,
                                                          cell: FakeCell) -> None:
    cell.release.clear()
    cell.started.clear()

    async def main() -> tuple[Any, ...]:
        async with Client(face.endpoint_url, timeout=20) as a, \
                Client(face.endpoint_url, timeout=20) as b:
            ns = await a.get_namespace_index(NAMESPACE)
            sa, sb = Session(a, ns), Session(b, ns)
            job = asyncio.create_task(sa.call("Locate", "slow"))
            assert await asyncio.to_thread(cell.started.wait, 20)
            during = await sb.values()
            codes = []
            for method, args in [("Locate", ["No.3"]), ("Identify", []), ("Reset", [])]:
                with pytest.raises(ua.UaStatusCodeError) as exc:
                    await sb.call(method, *args)
                codes.append(_code(exc))
            refusal = (await sb.values(["LastCallText"]))["LastCallText"]
            cell.release.set()
            outputs = await job
            return during, codes, refusal, outputs, await sb.values()

    during, codes, refusal, outputs, after = asyncio.run(main())
    assert (during["State"], during["StateNumber"]) == ("Busy", 7)
    assert during["Found"] is False and during["ResultId"] == ""   # nothing stale meanwhile
    assert codes == ["BadInvalidState"] * 3
    assert refusal == "Reset: busy with Locate('slow'); a search cannot be aborted"
    assert outputs[0] is True and after["ResultId"] == outputs[1]
    assert (after["State"], after["Model"], after["LastCallText"]) == ("Ready", "slow", "")


def test_the_address_space(face: OpcUaThread) -> None:
    async def body(s: Session) -> tuple[Any, ...]:
        children = {(await c.read_browse_name()).Name for c in await s.vision.get_children()}
        args = {}
        for method in ("Locate", "Identify"):
            props = {(await p.read_browse_name()).Name: await p.read_value()
                     for p in await s.node(method).get_properties()}
            args[method] = {k: [(a.Name, a.DataType.Identifier) for a in v]
                            for k, v in props.items()}
        ranks = [await s.node(n).read_value_rank() for n in ("PositionMm", "QuatWxyz")]
        dims = [await s.node(n).read_array_dimensions() for n in ("PositionMm", "QuatWxyz")]
        with pytest.raises(ua.UaStatusCodeError) as exc:            # read-only for clients
            await s.node("Found").write_value(True)
        return children, args, ranks, dims, _code(exc)

    children, args, ranks, dims, write = _run(face.endpoint_url, body)
    assert set(RESULT_VARS) | {"Locate", "Identify", "Reset"} <= children
    string, boolean = ua.ObjectIds.String, ua.ObjectIds.Boolean
    assert args["Locate"] == {"InputArguments": [("model", string)],
                              "OutputArguments": [("found", boolean), ("result_id", string)]}
    assert args["Identify"] == {"OutputArguments": [("found", boolean), ("model", string),
                                                    ("result_id", string)]}
    assert ranks == [1, 1] and dims == [[3], [4]]
    assert write == "BadUserAccessDenied"


@pytest.mark.parametrize("endpoint", ["opc.tcp://0.0.0.0:4840/photomodel/",
                                      "opc.tcp://192.168.0.10:4840/",
                                      "opc.tcp://cell-pc.local:4840/"])
def test_a_non_local_endpoint_needs_credentials(endpoint: str, cell: FakeCell) -> None:
    with pytest.raises(ValueError, match="needs credentials"):
        OpcUaFace(cell.locate, cell.identify, endpoint=endpoint)
    # with the service's token it is accepted (not started here: it would listen on the LAN)
    face = OpcUaFace(cell.locate, cell.identify, endpoint=endpoint, token=TOKEN)
    assert face.port == 4840


@pytest.mark.parametrize(("endpoint", "token", "match"), [
    ("http://127.0.0.1:4840/", None, "expected opc.tcp://HOST:PORT/PATH"),
    ("opc.tcp://127.0.0.1/photomodel/", None, "expected opc.tcp://HOST:PORT/PATH"),
    ("opc.tcp://127.0.0.1:99999/", None, "expected opc.tcp://HOST:PORT/PATH"),
    ("opc.tcp://127.0.0.1:4840/", "short", "token: expected one token"),
])
def test_bad_endpoints_and_tokens(endpoint: str, token: str | None, match: str,
                                  cell: FakeCell) -> None:
    with pytest.raises(InputError, match=match):
        OpcUaFace(cell.locate, cell.identify, endpoint=endpoint, token=token)


def test_credentials_accepted_and_refused(cell: FakeCell) -> None:
    async def body(s: Session) -> list[Any]:
        return await s.call("Locate", "No.3")

    with run_opcua_in_thread(OpcUaFace(cell.locate, cell.identify, endpoint=ENDPOINT,
                                       token=TOKEN)) as running:
        url = running.endpoint_url
        assert _run(url, body, user="photomodel", password=TOKEN)[0] is True
        refused = []
        for user, password in [(None, None), ("photomodel", TOKEN[:-1] + "x"),
                               ("admin", TOKEN)]:
            with pytest.raises(ua.UaStatusCodeError) as exc:
                _run(url, body, user=user, password=password)
            refused.append(_code(exc))
        # the server serves on after the refused logins
        assert _run(url, body, user="photomodel", password=TOKEN)[0] is True
    assert refused == ["BadIdentityTokenRejected", "BadUserAccessDenied",
                       "BadUserAccessDenied"]


def test_a_port_in_use_is_an_error_from_start(cell: FakeCell,
                                              caplog: pytest.LogCaptureFixture) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        handle = OpcUaThread(OpcUaFace(cell.locate, cell.identify,
                                       endpoint=f"opc.tcp://127.0.0.1:{port}/photomodel/"))
        with pytest.raises(OSError, match="address already in use"):
            handle.start()
        handle.stop()
    # the caller reports it in one line: asyncua's own traceback of it is not logged
    assert not [r for r in caplog.records if r.exc_info], caplog.text


def test_without_asyncua_the_error_names_the_extra(monkeypatch: pytest.MonkeyPatch,
                                                   cell: FakeCell) -> None:
    monkeypatch.setitem(sys.modules, "asyncua", None)
    with pytest.raises(ImportError, match=r"needs the 'plc' extra: pip install "
                                          r"photomodel\[plc\]"):
        OpcUaFace(cell.locate, cell.identify)


def test_the_example_client(face: OpcUaThread) -> None:
    env = {k: v for k, v in os.environ.items() if k != "PHOTOMODEL_TOKEN"}
    ok = subprocess.run([sys.executable, str(EXAMPLE), "--endpoint", face.endpoint_url,
                         "--model", "No.3"], capture_output=True, text=True, env=env,
                        timeout=120, check=False)
    assert ok.returncode == 0, ok.stderr
    lines = ok.stdout.splitlines()
    assert lines[0].startswith("Locate('No.3') -> found=True result_id=id-")
    assert "position_mm=[-49.4, -54.5, 691.9]" in lines[1] and "score=0.911" in lines[1]
    assert lines[2] == "state=Ready (6) error_text=''"
    bad = subprocess.run([sys.executable, str(EXAMPLE), "--endpoint", face.endpoint_url,
                          "--model", "X"], capture_output=True, text=True, env=env,
                         timeout=120, check=False)
    assert bad.returncode == 1 and bad.stdout == ""
    assert bad.stderr.strip().endswith("BadInvalidArgument: model: no model 'X' in the library")


def test_an_asyncua_older_than_2_is_named(monkeypatch: pytest.MonkeyPatch,
                                          cell: FakeCell) -> None:
    import importlib.metadata

    monkeypatch.setattr(importlib.metadata, "version", lambda name: "1.1.8")
    with pytest.raises(ImportError, match=r"needs asyncua 2.0 or later \(found 1.1.8\)"):
        OpcUaFace(cell.locate, cell.identify)


def test_serve_opcua_locates_from_its_camera_source(cell_data, tmp_path: Path) -> None:
    """``photomodel serve --source replay:... --opcua PORT`` as a PLC meets it: the example
    client's ``Locate`` grabs a pair from the source and answers with the pose."""
    import httpx

    http_port, opc_port = _free_tcp_port(), _free_tcp_port()
    endpoint = f"opc.tcp://127.0.0.1:{opc_port}/photomodel/"
    scene = cell_data.scene_of("No.3")
    replay = tmp_path / "replay"
    (replay / "000000").mkdir(parents=True)
    for view in ("right.png", "left.png"):
        (replay / "000000" / view).write_bytes((scene / view).read_bytes())
    serve = subprocess.Popen(
        [sys.executable, "-m", "photomodel", "serve", "--stereo", str(cell_data.stereo),
         "--models", str(cell_data.library), "--port", str(http_port), "--source",
         f"replay:{replay}", "--opcua", str(opc_port)],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 180
        while time.monotonic() < deadline:
            assert serve.poll() is None, serve.stderr.read() if serve.stderr else ""
            try:
                if httpx.get(f"http://127.0.0.1:{http_port}/health").json()["status"] == "ok":
                    break
            except httpx.HTTPError:
                pass
            time.sleep(1.0)
        ok = subprocess.run([sys.executable, str(EXAMPLE), "--endpoint", endpoint, "--model",
                             "No.3"], capture_output=True, text=True, timeout=120, check=False)
        assert ok.returncode == 0, ok.stderr
        assert "found=True" in ok.stdout and "state=Ready (6)" in ok.stdout
    finally:
        serve.terminate()
        serve.wait(timeout=30)


def test_serve_refuses_a_bad_opcua_port_in_one_line(capsys, cell_data) -> None:  # type: ignore[no-untyped-def]
    from photomodel.cli import main

    code = main(["serve", "--stereo", str(cell_data.stereo), "--models",
                 str(cell_data.library), "--opcua", "70000"])
    err = capsys.readouterr().err
    assert code == 2 and "--opcua" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def _free_tcp_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])
