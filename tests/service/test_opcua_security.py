"""The OPC UA face's security (``photomodel.service._opcua``): Basic256Sha256 SignAndEncrypt
with ``photomodel certs``' certificates and nothing else, client certificates trusted only
when the CA signed them (also the secure channel's own), the token file's users and roles
(``Register`` for ``admin`` only), the audit of logins and refusals, the throttle on failed
logins, the old single token, and the CLI's wiring (``_start_opcua``). asyncua's client over
loopback, fake callables in place of the cell."""

from __future__ import annotations

import asyncio
import logging
import threading
from collections.abc import Awaitable, Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("asyncua")

from asyncua import Client, ua  # noqa: E402
from asyncua.crypto import uacrypto  # noqa: E402
from asyncua.crypto.security_policies import SecurityPolicyBasic256Sha256  # noqa: E402
from cryptography import x509  # noqa: E402
from cryptography.hazmat.primitives import serialization  # noqa: E402

from photomodel.errors import InputError  # noqa: E402
from photomodel.service._audit import ACTOR, Actor, AuditLog, read_audit  # noqa: E402
from photomodel.service._auth import Credential, Throttle, TokenBook  # noqa: E402
from photomodel.service._certs import CLIENT_URI, CertFiles, make_certs  # noqa: E402
from photomodel.service._opcua import NAMESPACE, OpcUaFace, OpcUaThread  # noqa: E402

ENDPOINT = "opc.tcp://127.0.0.1:0/photomodel/"
CONTROLLER = "controller-token-0123456789"
ADMIN = "admin-token-0123456789abc"
TOKEN = "s3cret-token-0123456789"


@dataclass(frozen=True)
class Certs:
    """Two ``photomodel certs`` directories: ours (the face's CA) and another CA's."""

    ours: CertFiles
    other: CertFiles


@pytest.fixture(scope="module")
def certs(tmp_path_factory: pytest.TempPathFactory) -> Certs:
    root = tmp_path_factory.mktemp("certs")
    return Certs(make_certs(root / "ours", ["localhost"]),
                 make_certs(root / "other", ["localhost"]))


class FakeCell:
    """``locate``, ``identify`` and ``register`` as plain callables that remember who (the
    audit's :data:`ACTOR`) called them."""

    def __init__(self) -> None:
        self.actors: list[tuple[str, Actor | None]] = []
        self.lock = threading.Lock()

    def _seen(self, what: str) -> None:
        with self.lock:
            self.actors.append((what, ACTOR.get()))

    def locate(self, model: str) -> dict[str, Any]:
        self._seen(f"locate {model}")
        return {"model": model, "found": True, "position_mm": [1.0, 2.0, 3.0],
                "quat_wxyz": [1.0, 0.0, 0.0, 0.0], "score": 0.9, "id": "loc-1"}

    def identify(self) -> dict[str, Any]:
        self._seen("identify")
        return {"model": None, "found": False, "id": "id-1"}

    def register(self, name: str) -> dict[str, Any]:
        self._seen(f"register {name}")
        return {"name": name, "found": True, "position_mm": [0.0, 0.0, 500.0],
                "quat_wxyz": [1.0, 0.0, 0.0, 0.0], "id": "reg-1"}


class Books:
    """The credentials the face asks for at every login and request (as ``TokenFile.book``
    does): ``now`` may be replaced by a test."""

    def __init__(self) -> None:
        self.now = TokenBook([Credential("controller", "line-1", CONTROLLER),
                              Credential("admin", "boss", ADMIN)])

    def __call__(self) -> TokenBook:
        return self.now


@dataclass
class Secure:
    """The module's face: SignAndEncrypt, our CA trusted, the token book, an audit trail."""

    running: OpcUaThread
    cell: FakeCell
    books: Books
    audit: Path

    @property
    def url(self) -> str:
        return self.running.endpoint_url

    def events(self) -> list[dict[str, Any]]:
        return list(read_audit(self.audit)) if self.audit.exists() else []


@pytest.fixture(scope="module")
def secure(certs: Certs, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Secure]:
    cell, books = FakeCell(), Books()
    audit = tmp_path_factory.mktemp("audit") / "audit.jsonl"
    face = OpcUaFace(cell.locate, cell.identify, register=cell.register, endpoint=ENDPOINT,
                     tokens=books, certificate=certs.ours.server_cert,
                     private_key=certs.ours.server_key, ca=certs.ours.ca_cert,
                     audit=AuditLog(audit))
    with OpcUaThread(face) as running:
        yield Secure(running, cell, books, audit)


Body = Callable[[Client, int], Awaitable[Any]]


def _client(url: str, user: str | None, password: str | None) -> Client:
    client = Client(url, timeout=20)
    client.application_uri = CLIENT_URI       # the URI the client certificate names
    if user is not None:
        client.set_user(user)
    if password is not None:
        client.set_password(password)
    return client


async def _secure(client: Client, files: CertFiles, server: CertFiles) -> None:
    # the key file is PEM under the name .key: asyncua guesses DER from the suffix
    await client.set_security(SecurityPolicyBasic256Sha256, str(files.client_cert),
                              uacrypto.CertProperties(files.client_key, extension="pem"),
                              server_certificate=str(server.server_cert),
                              mode=ua.MessageSecurityMode.SignAndEncrypt)


def _run(url: str, body: Body, *, files: CertFiles | None = None,
         server: CertFiles | None = None, user: str | None = None,
         password: str | None = None,
         prepare: Callable[[Client], None] | None = None) -> Any:
    """``await body(client, ns)`` in a fresh session on ``url``: signed and encrypted with
    ``files``' client certificate when given (trusting ``server``'s server certificate)."""
    async def main() -> Any:
        client = _client(url, user, password)
        if files is not None:
            await _secure(client, files, server or files)
        if prepare is not None:
            prepare(client)
        async with client:
            return await body(client, await client.get_namespace_index(NAMESPACE))
    return asyncio.run(main())


def _call(method: str, *args: Any) -> Body:
    async def body(client: Client, ns: int) -> Any:
        vision = client.get_node(ua.NodeId("PhotomodelVision", ns))
        return await vision.call_method(ua.NodeId(f"PhotomodelVision.{method}", ns), *args)
    return body


def _code(exc: pytest.ExceptionInfo[ua.UaStatusCodeError]) -> str:
    return ua.status_codes.get_name_and_doc(exc.value.code)[0]


def _last(secure: Secure, action: str) -> dict[str, Any]:
    return [e for e in secure.events() if e["action"] == action][-1]


def test_sign_and_encrypt_locates_for_a_controller(secure: Secure, certs: Certs) -> None:
    out = _run(secure.url, _call("Locate", "No.3"), files=certs.ours, user="line-1",
               password=CONTROLLER)
    assert out == [True, "loc-1"]
    # the cell's work ran with the caller as the audit's actor
    assert secure.cell.actors[-1] == ("locate No.3",
                                      Actor("127.0.0.1", "controller", "line-1", "opcua"))
    login = _last(secure, "login")
    assert (login["client"], login["role"], login["user"], login["face"]) == \
        ("127.0.0.1", "controller", "line-1", "opcua")

    async def endpoints() -> list[ua.EndpointDescription]:
        return await Client(secure.url).connect_and_get_server_endpoints()

    offered = {(e.SecurityPolicyUri, e.SecurityMode) for e in asyncio.run(endpoints())}
    assert offered == {(SecurityPolicyBasic256Sha256.URI,
                        ua.MessageSecurityMode.SignAndEncrypt)}


def test_the_user_name_is_the_label_or_photomodel(secure: Secure, certs: Certs) -> None:
    assert _run(secure.url, _call("Identify"), files=certs.ours, user="photomodel",
                password=CONTROLLER) == [False, "", "id-1"]
    with pytest.raises(ua.UaStatusCodeError) as exc:    # another credential's label
        _run(secure.url, _call("Identify"), files=certs.ours, user="boss",
             password=CONTROLLER)
    assert _code(exc) == "BadUserAccessDenied"


def test_a_client_without_security_is_refused(secure: Secure,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    # asyncua's client finds no endpoint without security ...
    with pytest.raises(ua.UaError, match="No matching endpoints"):
        _run(secure.url, _call("Locate", "No.3"), user="line-1", password=CONTROLLER)

    # ... and one that takes the unsecured discovery channel anyway is refused by the server
    monkeypatch.setattr(Client, "find_endpoint",
                        staticmethod(lambda endpoints, mode, uri: endpoints[0]))
    calls = len(secure.cell.actors)
    with pytest.raises(ua.UaStatusCodeError) as exc:
        _run(secure.url, _call("Locate", "No.3"), user="line-1", password=CONTROLLER)
    assert _code(exc) == "BadSecurityModeRejected"
    assert len(secure.cell.actors) == calls
    refused = _last(secure, "refused")
    assert refused["status"] == "BadSecurityModeRejected" and refused["face"] == "opcua"


def test_a_certificate_of_another_ca_is_refused(secure: Secure, certs: Certs) -> None:
    with pytest.raises(ua.UaStatusCodeError) as exc:
        _run(secure.url, _call("Locate", "No.3"), files=certs.other, server=certs.ours,
             user="line-1", password=CONTROLLER)
    assert _code(exc) == "BadCertificateUntrusted"
    refused = _last(secure, "refused")
    assert refused["status"] == "BadCertificateUntrusted"
    assert refused["client"] == "127.0.0.1"
    assert refused["detail"].startswith("client certificate CN=photomodel client")


def test_a_trusted_certificate_named_over_an_untrusted_channel_is_refused(
        secure: Secure, certs: Certs) -> None:
    """The channel is signed with another CA's key while CreateSession names our client's
    (public) certificate: asyncua's validator sees only the latter; the face checks the
    channel's at activation."""
    trusted = x509.load_pem_x509_certificate(certs.ours.client_cert.read_bytes()) \
        .public_bytes(serialization.Encoding.DER)

    def swap(client: Client) -> None:
        create = client.uaclient.create_session

        async def create_session(params: ua.CreateSessionParameters) -> Any:
            params.ClientCertificate = trusted
            return await create(params)

        client.uaclient.create_session = create_session  # type: ignore[method-assign]

    calls = len(secure.cell.actors)
    with pytest.raises(ua.UaStatusCodeError) as exc:
        _run(secure.url, _call("Locate", "No.3"), files=certs.other, server=certs.ours,
             user="line-1", password=CONTROLLER, prepare=swap)
    assert _code(exc) == "BadCertificateUntrusted"
    assert len(secure.cell.actors) == calls


def test_register_needs_the_admin_role(secure: Secure, certs: Certs) -> None:
    with pytest.raises(ua.UaStatusCodeError) as exc:
        _run(secure.url, _call("Register", "No.9"), files=certs.ours, user="line-1",
             password=CONTROLLER)
    assert _code(exc) == "BadUserAccessDenied"
    assert not [a for a in secure.cell.actors if a[0] == "register No.9"]
    refused = _last(secure, "refused")
    assert (refused["status"], refused["detail"], refused["role"], refused["user"],
            refused["client"]) == ("BadUserAccessDenied", "Register", "controller", "line-1",
                                   "127.0.0.1")

    out = _run(secure.url, _call("Register", "No.9"), files=certs.ours, user="boss",
               password=ADMIN)
    assert out == [True, "No.9", "reg-1"]
    assert secure.cell.actors[-1] == ("register No.9",
                                      Actor("127.0.0.1", "admin", "boss", "opcua"))
    # an admin may do what a controller may
    assert _run(secure.url, _call("Locate", "No.3"), files=certs.ours, user="boss",
                password=ADMIN) == [True, "loc-1"]


def test_a_wrong_token_is_refused_and_audited(secure: Secure, certs: Certs) -> None:
    with pytest.raises(ua.UaStatusCodeError) as exc:
        _run(secure.url, _call("Locate", "No.3"), files=certs.ours, user="line-1",
             password=CONTROLLER[:-1] + "x")
    assert _code(exc) == "BadUserAccessDenied"
    failed = _last(secure, "login-failed")
    assert (failed["client"], failed["user"], failed["face"], failed["role"],
            failed["status"], failed["detail"]) == \
        ("127.0.0.1", "line-1", "opcua", None, "BadUserAccessDenied",
         "wrong user name or token")
    assert CONTROLLER[:-1] not in secure.audit.read_text()     # no token in the trail


def test_a_token_taken_out_of_the_book_stops_its_session(secure: Secure,
                                                          certs: Certs) -> None:
    async def body(client: Client, ns: int) -> list[Any]:
        first = await _call("Locate", "No.3")(client, ns)
        before = secure.books.now
        secure.books.now = TokenBook([c for c in before.credentials if c.label != "line-1"])
        try:
            with pytest.raises(ua.UaStatusCodeError) as exc:
                await _call("Locate", "No.3")(client, ns)
        finally:
            secure.books.now = before
        return [first, _code(exc)]

    assert _run(secure.url, body, files=certs.ours, user="line-1",
                password=CONTROLLER) == [[True, "loc-1"], "BadUserAccessDenied"]


def test_the_nodes_stay_in_namespace_2_with_certificates(secure: Secure,
                                                         certs: Certs) -> None:
    async def ns(client: Client, index: int) -> int:
        return index

    assert _run(secure.url, ns, files=certs.ours, user="line-1", password=CONTROLLER) == 2


def test_failed_logins_are_throttled_per_address(tmp_path: Path) -> None:
    cell, audit = FakeCell(), tmp_path / "audit.jsonl"
    face = OpcUaFace(cell.locate, cell.identify, endpoint=ENDPOINT, tokens=Books(),
                     audit=AuditLog(audit))
    face.throttle = Throttle(failures=2)
    codes = []
    with OpcUaThread(face) as running:
        for password in [ADMIN[:-1] + "x", ADMIN[:-1] + "y", ADMIN]:
            with pytest.raises(ua.UaStatusCodeError) as exc:
                _run(running.endpoint_url, _call("Locate", "No.3"), user="boss",
                     password=password)
            codes.append(_code(exc))
    assert codes == ["BadUserAccessDenied"] * 3
    events = list(read_audit(audit))
    assert [e["action"] for e in events] == ["login-failed", "login-failed", "refused"]
    assert "too many failed logins from 127.0.0.1" in events[-1]["detail"]
    assert cell.actors == []


def test_the_single_token_works_as_before(caplog: pytest.LogCaptureFixture,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    import photomodel.service._server as server_module

    cell = FakeCell()
    face = OpcUaFace(cell.locate, cell.identify, register=cell.register, endpoint=ENDPOINT,
                     token=TOKEN)
    # as if 127.0.0.1 were a LAN address: the unencrypted traffic is one warning at start
    monkeypatch.setattr(server_module, "is_loopback", lambda host: False)
    with caplog.at_level(logging.WARNING, logger="photomodel.service.opcua"), \
            OpcUaThread(face) as running:
        url = running.endpoint_url
        assert _run(url, _call("Locate", "No.3"), user="photomodel",
                    password=TOKEN) == [True, "loc-1"]
        assert _run(url, _call("Register", "No.7"), user="photomodel",
                    password=TOKEN) == [True, "No.7", "reg-1"]     # the token is an admin
        with pytest.raises(ua.UaStatusCodeError) as exc:
            _run(url, _call("Locate", "No.3"), user="admin", password=TOKEN)
    assert _code(exc) == "BadUserAccessDenied"
    assert cell.actors[-1] == ("register No.7",
                               Actor("127.0.0.1", "admin", "photomodel", "opcua"))
    warnings = [r.getMessage() for r in caplog.records if "not encrypted" in r.getMessage()]
    assert len(warnings) == 1 and "127.0.0.1" in warnings[0]


def test_without_credentials_local_anonymous_calls_are_the_admins(tmp_path: Path) -> None:
    cell = FakeCell()
    face = OpcUaFace(cell.locate, cell.identify, register=cell.register, endpoint=ENDPOINT)
    with OpcUaThread(face) as running:
        assert _run(running.endpoint_url, _call("Register", "No.8")) == [True, "No.8",
                                                                          "reg-1"]
    assert cell.actors == [("register No.8", Actor("127.0.0.1", "admin", None, "opcua"))]


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"certificate": "ours.server_cert"}, "private_key: certificate and private_key go "
                                          "together"),
    ({"private_key": "ours.server_key"}, "certificate: certificate and private_key go "
                                         "together"),
    ({"ca": "ours.ca_cert"}, "ca: trusting client certificates needs"),
    ({"certificate": "ours.server_cert", "private_key": "other.server_key"},
     "is not the key of"),
    ({"certificate": "ours.server_key", "private_key": "ours.server_key"},
     "not an X.509 certificate"),
    ({"certificate": "ours.server_cert", "private_key": "ours.server_cert"},
     "not an unencrypted private key"),
    ({"token": TOKEN, "tokens": "book"}, "give token or tokens, not both"),
    ({"tokens": "empty"}, "tokens: no credential"),
])
def test_bad_security_arguments(kwargs: dict[str, str], match: str, certs: Certs) -> None:
    def value(name: str, spec: str) -> Any:
        if name == "token":
            return spec
        if spec == "book":
            return Books()
        if spec == "empty":
            return TokenBook([])
        which, field = spec.split(".")
        return getattr(getattr(certs, which), field)

    cell = FakeCell()
    with pytest.raises(InputError, match=match):
        OpcUaFace(cell.locate, cell.identify, endpoint=ENDPOINT,
                  **{k: value(k, v) for k, v in kwargs.items()})


def test_a_non_local_endpoint_with_certificates_still_needs_credentials(
        certs: Certs) -> None:
    cell = FakeCell()
    with pytest.raises(InputError, match="needs credentials"):
        OpcUaFace(cell.locate, cell.identify, endpoint="opc.tcp://0.0.0.0:4840/photomodel/",
                  certificate=certs.ours.server_cert, private_key=certs.ours.server_key)


def test_serve_wiring_passes_tokens_certificates_ca_and_audit(certs: Certs,
                                                              tmp_path: Path) -> None:
    """``_start_opcua`` as ``photomodel serve`` calls it: the cell's tokens, the TLS pair,
    the CA (by default ``ca.pem`` beside the certificate) and the cell's audit trail."""
    from photomodel.cli._serve import _start_opcua

    fake = FakeCell()

    class Threads:
        def call(self, job: Callable[[], Any]) -> Any:
            return job()

    class Cell:
        threads = Threads()
        trigger_locate = staticmethod(fake.locate)
        trigger_identify = staticmethod(fake.identify)
        tokens = Books()
        audit = AuditLog(tmp_path / "audit.jsonl")

    @dataclass(frozen=True)
    class Tls:
        cert: Path
        key: Path

    handle = _start_opcua(Cell(), "127.0.0.1", 0, Cell.tokens,
                          Tls(certs.ours.server_cert, certs.ours.server_key), None)
    try:
        assert handle.face.encrypted
        assert _run(handle.endpoint_url, _call("Locate", "No.3"), files=certs.ours,
                    user="line-1", password=CONTROLLER) == [True, "loc-1"]
        with pytest.raises(ua.UaStatusCodeError) as exc:
            _run(handle.endpoint_url, _call("Locate", "No.3"), files=certs.other,
                 server=certs.ours, user="line-1", password=CONTROLLER)
        assert _code(exc) == "BadCertificateUntrusted"
    finally:
        handle.stop()
    assert [e["action"] for e in read_audit(Cell.audit.path)] == ["login", "refused"]
    assert fake.actors == [("locate No.3",
                            Actor("127.0.0.1", "controller", "line-1", "opcua"))]
