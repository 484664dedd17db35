"""The service on a factory network, over real HTTPS: TLS with the certificates that
``photomodel certs`` makes, the two roles, browser sessions with CSRF, the throttle on failed
authentication, token rotation and the audit trail."""

from __future__ import annotations

import datetime as dt
import json
import shutil
import ssl
import time
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace

import httpx
import pytest
from websockets.sync.client import connect

from photomodel.service import CellService, ServiceConfig, ServiceThread, TlsFiles, make_certs
from photomodel.service._audit import read_audit
from photomodel.service._track_socket import encode_frame

ADMIN, CONTROLLER = "admin-token-0123456789", "controller-token-0123456789"
TIMEOUT_S = 120.0


@pytest.fixture(scope="module")
def certs(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    return make_certs(tmp_path_factory.mktemp("certs"), ["cell-7.plant"])


@pytest.fixture(scope="module")
def secure(cell_data, certs, tmp_path_factory: pytest.TempPathFactory
           ) -> Iterator[SimpleNamespace]:
    """A warmed TLS service with an admin and a controller token, the model station's
    camera and a replayed camera source."""
    root = tmp_path_factory.mktemp("secure")
    library = root / "library"
    shutil.copytree(cell_data.library, library)
    sequence = root / "seq"
    for k in range(2):
        shutil.copytree(cell_data.scene_of("No.3"), sequence / f"{k:06d}")
    (sequence / "meta.json").write_text(json.dumps({"fps": 10}))
    tokens = root / "tokens.txt"
    tokens.write_text(f"# role token label\nadmin {ADMIN} alice\ncontroller {CONTROLLER} "
                      "plc-7\n")
    cell = CellService(ServiceConfig(stereo=cell_data.stereo, models=library,
                                     camera=cell_data.camera, token_file=tokens,
                                     source=f"replay:{sequence}", record_dir=root / "rec",
                                     tls=True))
    with ServiceThread(cell, tls=TlsFiles(certs.server_cert, certs.server_key)) as running:
        running.wait_ready()
        yield SimpleNamespace(url=running.url, cell=cell, tokens=tokens, root=root,
                              audit=library / "audit" / "audit.jsonl")
    cell.close()


def _client(secure: SimpleNamespace, certs, token: str | None = None,  # type: ignore[no-untyped-def]
            address: str = "127.0.0.1") -> httpx.Client:
    """A client trusting the generated CA, from ``address`` (another loopback address is
    another client to the throttle)."""
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    context = ssl.create_default_context(cafile=str(certs.ca_cert))
    return httpx.Client(base_url=secure.url, headers=headers, timeout=TIMEOUT_S,
                        transport=httpx.HTTPTransport(local_address=address, verify=context))


def _pair(cell_data) -> dict[str, bytes]:  # type: ignore[no-untyped-def]
    scene = cell_data.scene_of("No.3")
    return {"right": (scene / "right.png").read_bytes(), "left": (scene / "left.png").read_bytes()}


def _events(secure: SimpleNamespace) -> list[dict]:
    return list(read_audit(secure.audit)) if secure.audit.exists() else []


def test_every_endpoint_answers_over_https(secure, certs, cell_data) -> None:
    with _client(secure, certs, ADMIN) as c:
        health = c.get("/health").json()
        assert health["status"] == "ok" and health["tls"] is True and health["warning"] is None
        assert c.get("/models").json()[0]["name"] == "No.3"
        assert c.get("/models/No.3/preview.png").headers["content-type"] == "image/png"
        found = c.post("/locate", data={"model": "No.3", "seed": "1"}, files=_pair(cell_data))
        assert found.status_code == 200 and found.json()["found"]
        rid = found.json()["id"]
        assert c.get(f"/results/{rid}").json()["id"] == rid
        assert c.get(f"/results/{rid}/overlay.png").status_code == 200
        assert c.post("/identify", files=_pair(cell_data)).json()["model"] == "No.3"
        assert c.post("/trigger/locate", data={"model": "No.3"}).status_code == 200
        assert c.post("/trigger/identify").status_code == 200
        assert c.get("/camera/latest.jpg").headers["content-type"] == "image/jpeg"
        assert c.get("/results").status_code == 200 and c.get("/stats").status_code == 200
        assert "photomodel_requests" in c.get("/metrics").text
        assert c.get("/").status_code == 200
        assert c.get("/session").json() == {"user": "alice", "role": "admin", "csrf": None,
                                            "login": True}
    context = ssl.create_default_context(cafile=str(certs.ca_cert))
    right, left = _pair(cell_data).values()
    url = secure.url.replace("https://", "wss://")
    with connect(f"{url}/track?model=No.3", ssl=context, max_size=2**25, open_timeout=30,
                 additional_headers={"Authorization": f"Bearer {CONTROLLER}"}) as ws:
        ws.send(encode_frame(right, left, t_s=0.0))
        assert json.loads(ws.recv(timeout=60))["found"]


def test_plain_http_to_the_tls_port_fails_cleanly_and_the_service_serves_on(secure, certs
                                                                            ) -> None:
    plain = secure.url.replace("https://", "http://")
    with pytest.raises(httpx.HTTPError):
        httpx.get(f"{plain}/health", headers={"Authorization": f"Bearer {ADMIN}"}, timeout=10)
    with _client(secure, certs, ADMIN) as c:
        assert c.get("/health").status_code == 200


def test_a_client_refuses_an_untrusted_or_expired_certificate(secure, certs, cell_data,
                                                              tmp_path) -> None:
    other = make_certs(tmp_path / "other", ["cell-7.plant"])
    with pytest.raises(httpx.ConnectError, match="CERTIFICATE_VERIFY_FAILED"):
        httpx.get(f"{secure.url}/health", verify=ssl.create_default_context(
            cafile=str(other.ca_cert)))
    with pytest.raises(httpx.ConnectError, match="CERTIFICATE_VERIFY_FAILED"):
        httpx.get(f"{secure.url}/health")                  # the system's CAs only
    old = make_certs(tmp_path / "old", ["localhost"], days=1,
                     not_before=dt.datetime.now(dt.UTC) - dt.timedelta(days=3))
    expired = CellService(ServiceConfig(stereo=cell_data.stereo, models=tmp_path / "lib",
                                        tls=True))
    with ServiceThread(expired, warm=False, tls=TlsFiles(old.server_cert, old.server_key)
                       ) as running:
        with pytest.raises(httpx.ConnectError, match="expired"):
            httpx.get(f"{running.url}/health", verify=ssl.create_default_context(
                cafile=str(old.ca_cert)))
    expired.close()


def test_a_controller_may_not_change_the_library_an_admin_may(secure, certs, cell_data
                                                               ) -> None:
    model_dir = cell_data.dataset / "models" / "No.5"
    photos = {"photo": (model_dir / "photo.bmp").read_bytes(),
              "background": (model_dir / "background.bmp").read_bytes()}
    with _client(secure, certs, CONTROLLER) as c:
        for response in (c.post("/models", data={"name": "No.5"}, files=photos),
                         c.delete("/models/No.3"),
                         c.post("/models/No.3/scale", data={"factor": "1.01"}),
                         c.post("/record?frames=1")):
            assert response.status_code == 403, response.text
            assert "needs the admin role" in response.json()["error"]
        assert c.post("/locate", data={"model": "No.3"}, files=_pair(cell_data)
                      ).status_code == 200
        assert c.post("/identify", files=_pair(cell_data)).status_code == 200
        assert c.post("/trigger/locate", data={"model": "No.3"}).status_code == 200
    with _client(secure, certs, ADMIN) as c:
        assert c.post("/models", data={"name": "No.5"}, files=photos).status_code == 201
        assert c.post("/record?frames=1").status_code == 201
        assert c.delete("/models/No.5").status_code == 200


def test_a_browser_session_holds_no_token_and_needs_csrf_for_changes(secure, certs) -> None:
    with _client(secure, certs) as browser:
        assert browser.get("/").headers["location"] == "login"
        done = browser.post("/login", data={"token": ADMIN})
        assert done.status_code == 303
        cookie = done.headers["set-cookie"]
        assert ADMIN not in cookie and "photomodel_session=" in cookie
        for flag in ("httponly", "samesite=strict", "secure"):
            assert flag in cookie.lower()
        me = browser.get("/session").json()
        assert me["user"] == "alice" and len(me["csrf"]) >= 32
        refused = browser.delete("/models/nothing")
        assert refused.status_code == 403 and "CSRF" in refused.json()["error"]
        allowed = browser.delete("/models/nothing", headers={"X-CSRF-Token": me["csrf"]})
        assert allowed.status_code == 404                   # past the guard
        sid = browser.cookies["photomodel_session"]
        assert browser.get("/logout").status_code == 303
    with _client(secure, certs) as replay:        # the ended session's id opens nothing
        replay.cookies.set("photomodel_session", sid)
        assert replay.get("/health").status_code == 401


def test_wrong_tokens_are_throttled_per_client(secure, certs) -> None:
    statuses, waits = [], []
    with _client(secure, certs, "wrong-token-0000000000", address="127.0.0.3") as bad, \
            _client(secure, certs, CONTROLLER, address="127.0.0.4") as good:
        other = []
        for _ in range(20):
            response = bad.get("/health")
            statuses.append(response.status_code)
            waits.append(response.headers.get("retry-after"))
            other.append(good.get("/health").status_code)
        right_but_blocked = bad.get("/health", headers={"Authorization": f"Bearer {ADMIN}"})
    assert statuses == [401] * 10 + [429] * 10
    assert all(w is not None and 1 <= int(w) <= 60 for w in waits[10:])
    assert other == [200] * 20                       # another client is not slowed
    assert right_but_blocked.status_code == 429      # no more guesses from that address
    refused = [e for e in _events(secure) if e["client"] == "127.0.0.3"]
    assert [e["status"] for e in refused] == [401] * 10 + [429]   # a flood: one line a minute
    assert "counted, not logged" in refused[-1]["detail"]


def test_a_rotated_token_file_takes_effect_and_ends_old_sessions(secure, certs) -> None:
    original = secure.tokens.read_text()
    try:
        with _client(secure, certs) as browser:
            assert browser.post("/login", data={"token": CONTROLLER}).status_code == 303
            assert browser.get("/health").status_code == 200
            new = "controller-token-rotated-42"
            secure.tokens.write_text(f"admin {ADMIN} alice\ncontroller {new} plc-7\n")
            deadline = time.monotonic() + 10
            while browser.get("/health").status_code != 401:
                assert time.monotonic() < deadline, "the rotated file was not read"
                time.sleep(0.2)
            with _client(secure, certs, new) as c:
                assert c.get("/health").status_code == 200
            with _client(secure, certs, CONTROLLER, address="127.0.0.5") as c:
                assert c.get("/health").status_code == 401
    finally:
        secure.tokens.write_text(original)
        time.sleep(1.2)


def test_the_audit_trail_holds_a_scripted_session(secure, certs, cell_data) -> None:
    model_dir = cell_data.dataset / "models" / "No.5"
    photos = {"photo": (model_dir / "photo.bmp").read_bytes(),
              "background": (model_dir / "background.bmp").read_bytes()}
    before = len(_events(secure))
    with _client(secure, certs, address="127.0.0.6") as browser:
        assert browser.post("/login", data={"token": "not-the-token-000000"}
                            ).status_code == 401
        assert browser.post("/login", data={"token": ADMIN}).status_code == 303
        csrf = {"X-CSRF-Token": browser.get("/session").json()["csrf"]}
        assert browser.post("/models", data={"name": "No.5"}, files=photos,
                            headers=csrf).status_code == 201
        assert browser.post("/models", data={"name": "No.5", "replace": "true"},
                            files=photos, headers=csrf).status_code == 201
        assert browser.delete("/models/No.5", headers=csrf).status_code == 200
        assert browser.get("/logout").status_code == 303
    with _client(secure, certs, CONTROLLER, address="127.0.0.6") as c:
        assert c.delete("/models/No.3").status_code == 403
    events = _events(secure)[before:]
    assert [(e["action"], e["user"], e["model"], e["status"]) for e in events] == [
        ("login-failed", None, None, 401), ("login", "alice", None, 303),
        ("register", "alice", "No.5", None), ("replace", "alice", "No.5", None),
        ("delete", "alice", "No.5", None), ("logout", "alice", None, 303),
        ("refused", "plc-7", None, 403)]
    assert all(e["client"] == "127.0.0.6" and e["face"] == "http" for e in events)
    hashes = [e["sha256"] for e in events[2:5]]
    assert all(h is not None and len(h) == 64 for h in hashes) and hashes[2] == hashes[1]


def test_a_public_bind_without_tls_is_warned_about(cell_data, tmp_path) -> None:
    cell = CellService(ServiceConfig(stereo=cell_data.stereo, models=tmp_path / "lib",
                                     token="a-token-of-16-chars-or-more", host="0.0.0.0"))
    assert "without TLS" in cell.health()["warning"]
    cell.close()
    assert CellService(ServiceConfig(stereo=cell_data.stereo, models=tmp_path / "lib2",
                                     host="0.0.0.0", tls=True)).health()["warning"] is None


def test_the_example_client_locates_over_https_with_the_ca(secure, certs, cell_data) -> None:
    import os
    import subprocess
    import sys

    example = Path(__file__).resolve().parents[2] / "examples" / "locate_client.py"
    scene = cell_data.scene_of("No.3")
    env = os.environ | {"PHOTOMODEL_TOKEN": CONTROLLER, "PHOTOMODEL_CA": str(certs.ca_cert)}
    done = subprocess.run([sys.executable, str(example), secure.url, "No.3",
                           str(scene / "right.png"), str(scene / "left.png"), "1"],
                          env=env, capture_output=True, text=True, timeout=TIMEOUT_S)
    assert done.returncode == 0 and done.stdout.startswith("found=True"), done.stderr
    env.pop("PHOTOMODEL_CA")                       # the system's CAs do not know ours
    refused = subprocess.run([sys.executable, str(example), secure.url, "No.3",
                              str(scene / "right.png"), str(scene / "left.png")],
                             env=env, capture_output=True, text=True, timeout=TIMEOUT_S)
    assert refused.returncode != 0 and "CERTIFICATE_VERIFY_FAILED" in refused.stderr


def test_serve_warns_at_start_of_a_public_bind_without_tls(cell_data, tmp_path) -> None:
    import socket
    import subprocess
    import sys

    tokens = tmp_path / "tokens.txt"
    tokens.write_text(f"controller {CONTROLLER}\n")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    serve = subprocess.Popen([sys.executable, "-m", "photomodel", "serve", "--stereo",
                              str(cell_data.stereo), "--models", str(tmp_path / "lib"),
                              "--host", "0.0.0.0", "--port", str(port), "--token-file",
                              str(tokens)], stderr=subprocess.PIPE, text=True)
    try:
        assert serve.stderr is not None
        lines = [serve.stderr.readline() for _ in range(3)]
    finally:
        serve.terminate()
        serve.wait(timeout=30)
    warnings = [line for line in lines if "warning" in line]
    assert len(warnings) == 1 and "without TLS" in warnings[0] and "--tls-cert" in warnings[0]


def test_the_generated_certificates_pass_serves_check(certs, tmp_path) -> None:
    from photomodel.errors import InputError

    TlsFiles(certs.server_cert, certs.server_key).check()
    other = make_certs(tmp_path / "other", ["cell-7.plant"])
    with pytest.raises(InputError, match="cannot serve TLS"):
        TlsFiles(certs.server_cert, other.server_key).check()
    with pytest.raises(InputError, match="--tls-key: .*not a PEM file"):
        TlsFiles(certs.server_cert, certs.server_cert).check()
