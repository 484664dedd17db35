"""The cell service's OPC UA face: a PLC calls ``Locate(model)``, ``Identify()`` or
``Register(name)`` and reads the pose from variables (``photomodel serve --opcua PORT``;
contract in docs/contracts.md, design in docs/method/opcua.md).

The face is a thin adapter: it takes blocking callables (for the service,
``CellService.trigger_locate`` and ``trigger_identify``, which grab a fresh stereo pair and
answer as HTTP ``/trigger/locate`` and ``/trigger/identify`` do, and optionally
``register_from_camera``, which builds a model of the garment where it lies and answers
where that is) and runs them one at a time
in a worker thread, never on the server's event loop. ``asyncua`` (the ``plc`` extra) is
imported only when a face is built.

Security, on asyncua's own hooks: with a certificate the only endpoint is Basic256Sha256
SignAndEncrypt and asyncua's certificate validator (:class:`ClientCertificates`) accepts
client certificates signed by the given CA only (checked again, on the secure channel's own
certificate, at every session activation: :func:`internal_server_class`); the user manager
(:class:`Users`) maps a user name and token to the token file's credential; the permission
ruleset (:class:`Rules`), which asyncua asks before every request, refuses ``Register`` to
a role below ``admin`` and hands the caller to the method (a contextvar: asyncua serves each
connection in its own task). Logins, failed logins and refusals go to the audit trail.
"""

from __future__ import annotations

import asyncio
import contextvars
import enum
import logging
import math
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from datetime import UTC, datetime
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any
from urllib.parse import urlsplit

from photomodel.errors import InputError, PhotomodelError
from photomodel.service._audit import ACTOR, AuditLog
from photomodel.service._auth import Throttle, TokenBook, allows
from photomodel.service._certs import APPLICATION_URI
from photomodel.service._opcua_security import (
    CALLER,
    SECURE_POLICY,
    USER,
    ClientCertificates,
    Rules,
    Users,
    caller_actor,
    check_tokens,
    internal_server_class,
    load_tls,
)

if TYPE_CHECKING:
    from asyncua import Server, ua

__all__ = ["DEFAULT_ENDPOINT", "NAMESPACE", "OBJECT_NAME", "OpcUaFace", "OpcUaThread",
           "State", "run_opcua_in_thread"]

DEFAULT_ENDPOINT = "opc.tcp://127.0.0.1:4840/photomodel/"
"""Where the face listens unless told otherwise: this machine only."""

NAMESPACE = "urn:photomodel:cell"
"""The namespace of the face's nodes (index 2 on a fresh server: the first registered)."""

OBJECT_NAME = "PhotomodelVision"
"""The object under ``Objects`` that holds the methods and the result variables; every node's
id is the string ``PhotomodelVision.<BrowseName>`` in :data:`NAMESPACE`."""


_EXTRA_HINT = "the OPC UA face needs the 'plc' extra: pip install photomodel[plc]"
_NO_TIME = datetime(1601, 1, 1, tzinfo=UTC)   # OPC UA's null DateTime
_log = logging.getLogger("photomodel.service.opcua")


class State(enum.Enum):
    """The face's state, modelled on OPC 40100's vision state machine; the value is the
    ``StateNumber`` that OPC 40100 gives the state it stands for (Ready and SingleExecution
    of its automatic mode, Error of the top level)."""

    READY = 6
    BUSY = 7
    ERROR = 3

    @property
    def text(self) -> str:
        """The ``State`` variable's value: ``"Ready"``, ``"Busy"`` or ``"Error"``."""
        return self.name.capitalize()


class _NoStartTraceback(logging.Filter):
    """Drops asyncua's own traceback of a failed start (a port in use): the face raises the
    error to its caller, who reports it in one line."""

    def filter(self, record: logging.LogRecord) -> bool:
        return "error starting server" not in str(record.msg)


_START_FILTER = _NoStartTraceback()


def _import_asyncua() -> Any:
    try:
        import asyncua
    except ImportError:
        raise ImportError(_EXTRA_HINT) from None
    from importlib.metadata import PackageNotFoundError, version

    try:
        found = version("asyncua")
    except PackageNotFoundError:     # imported from a source tree: trust it
        return asyncua
    major = found.split(".")[0]
    if major.isdigit() and int(major) < 2:
        raise ImportError(f"the OPC UA face needs asyncua 2.0 or later (found {found}): "
                          "pip install -U 'photomodel[plc]'")
    return asyncua


def _check_endpoint(endpoint: str, credentials: bool) -> tuple[str, int]:
    """The host and port of ``endpoint`` (``opc.tcp://HOST:PORT/PATH``; port 0 takes a free
    one); InputError (a ValueError) for another form, and for a host that is not this machine
    only (127.0.0.0/8, ::1, ``localhost``) without ``credentials``."""
    from photomodel.service._server import is_loopback

    try:
        parts = urlsplit(endpoint)
        port = parts.port
    except ValueError as exc:
        raise InputError("endpoint", f"expected opc.tcp://HOST:PORT/PATH, got {endpoint!r} "
                                     f"({exc})") from None
    if parts.scheme != "opc.tcp" or not parts.hostname or port is None:
        raise InputError("endpoint", f"expected opc.tcp://HOST:PORT/PATH, got {endpoint!r}")
    if not credentials and not is_loopback(parts.hostname):
        raise InputError("endpoint", f"binding OPC UA to {parts.hostname} (not this machine "
                                     "only) needs credentials: give the service's tokens "
                                     "(--token-file); clients then log in with a token as "
                                     f"password and its label (or {USER!r}) as user name")
    return parts.hostname, port


class _Refused(Exception):
    """A call answered with a Bad status before any work (busy, wrong arguments)."""

    def __init__(self, code: int, text: str, argument: int | None = None) -> None:
        super().__init__(text)
        self.code = code
        self.text = text
        self.argument = argument


def _status_of(exc: BaseException) -> tuple[int, str]:
    """The Bad status code and the one-line text that answer a failed job: the HTTP side's
    mapping (404 BadNotFound, 409 BadInvalidState, 503 BadResourceUnavailable, other input
    errors 400 BadInvalidArgument; anything else BadInternalError)."""
    from asyncua import ua

    from photomodel.service._cell import Conflict, NotFound, Unavailable
    from photomodel.service._source import SourceError  # a source that cannot give a pair

    if isinstance(exc, NotFound):
        return ua.StatusCodes.BadNotFound, str(exc)
    if isinstance(exc, (Unavailable, SourceError)):
        return ua.StatusCodes.BadResourceUnavailable, str(exc)
    if isinstance(exc, Conflict):
        return ua.StatusCodes.BadInvalidState, str(exc)
    if isinstance(exc, PhotomodelError):
        return ua.StatusCodes.BadInvalidArgument, str(exc)
    return ua.StatusCodes.BadInternalError, (f"internal error ({type(exc).__name__}: {exc}); "
                                             "the service log has the details")


def _numbers(value: Any, n: int) -> list[float]:
    """``n`` floats from a JSON list (NaN for null or a missing list)."""
    if not isinstance(value, Sequence) or len(value) != n:
        return [math.nan] * n
    return [math.nan if v is None else float(v) for v in value]


def _number(value: Any) -> float:
    return math.nan if value is None else float(value)


def _frame_time(answer: dict[str, Any]) -> datetime:
    """When the answer's frame was taken (UTC): its ``frame_t_s`` (Unix seconds), else the
    ``pose_stamped`` header's stamp, else now."""
    t = answer.get("frame_t_s")
    if t is None:
        stamped = answer.get("pose_stamped")
        if isinstance(stamped, dict):
            t = stamped.get("header", {}).get("stamp")
    if t is None:
        t = time.time()
    return datetime.fromtimestamp(float(t), UTC)


class OpcUaFace:
    """An OPC UA server with one object, ``PhotomodelVision``, whose methods run the given
    callables and whose variables hold the last result and the state.

    Parameters
    ----------
    locate : callable
        ``locate(model) -> dict``: the ``/locate`` answer (the ``locate --json`` object plus
        ``id``) for a fresh frame; raises a :class:`PhotomodelError` with a one-line message
        on failure. Blocking: it runs in the face's worker thread, in a copy of the caller's
        context with :data:`~photomodel.service._audit.ACTOR` set (face ``opcua``).
    identify : callable
        ``identify() -> dict``: the ``/identify`` answer for a fresh frame, likewise.
    register : callable or None
        ``register(name) -> dict``: build and add a model of the garment where it lies (the
        ``Register`` method; absent without it). Only an ``admin`` credential may call it.
    endpoint : str
        ``opc.tcp://HOST:PORT/PATH`` to listen on; port 0 takes a free one (see
        :attr:`endpoint_url` once started). Only this machine unless there are credentials
        (``tokens`` or ``token``); beyond it without a certificate, a warning is logged that
        the traffic is not encrypted.
    token : str or None
        One token (earlier versions' single token): an ``admin`` credential whose user name
        is :data:`USER`. Not with ``tokens``.
    tokens : TokenBook or callable or None
        The credentials (:class:`~photomodel.service._auth.TokenBook`, or a callable giving
        the current ones, such as ``TokenFile(path).book``, asked at every login and
        request: a removed token stops working, a changed role applies at once). Clients
        log in with a credential's token as password and its label, or :data:`USER`, as
        user name; anonymous sessions are refused. ``Register`` needs the ``admin`` role,
        the other methods ``controller``. Without credentials, any local client may connect
        anonymously and call every method.
    certificate, private_key : Path or None
        The server's certificate (PEM, or DER; a chain's first) and its unencrypted RSA key
        (2048 to 4096 bits), together. With them, the only endpoint is Basic256Sha256
        SignAndEncrypt (:data:`SECURE_POLICY`: no unencrypted one), and the server's
        ApplicationUri is the first URI the certificate names (``photomodel certs``:
        :data:`~photomodel.service._certs.APPLICATION_URI`).
    ca : Path or None
        The CA certificate whose signed client certificates are trusted; a client whose
        certificate it did not sign, that is expired, or whose key usage, extended key usage
        (clientAuth) or URI (the client's ApplicationUri) does not fit, is refused
        (``BadCertificateUntrusted`` and kin). Without it, and with a certificate, any client
        certificate that fits is accepted (logged as a warning at start).
    audit : AuditLog or None
        Where logins (``login``), failed logins (``login-failed``), refusals (``refused``:
        a role's forbidden call, a throttled login, an untrusted client certificate) go,
        each with face ``opcua``, the client's address and the user.

    Attributes
    ----------
    throttle : Throttle
        Failed logins per client address: from 10 within a minute, a login from that
        address is refused without looking at its token until the oldest is a minute old
        (another may be set before :meth:`start`).

    Raises
    ------
    ImportError
        Without ``asyncua`` (the ``plc`` extra).
    InputError
        An endpoint of another form, one that is not local without credentials, both
        ``token`` and ``tokens``, a certificate without its key (or the reverse, or ``ca``
        alone), or a certificate, key or CA that cannot serve.

    Examples
    --------
    >>> face = OpcUaFace(cell.trigger_locate, cell.trigger_identify)   # doctest: +SKIP
    >>> handle = run_opcua_in_thread(face)                             # doctest: +SKIP
    >>> handle.stop()                                                  # doctest: +SKIP
    """

    def __init__(self, locate: Callable[[str], dict[str, Any]],
                 identify: Callable[[], dict[str, Any]], *,
                 register: Callable[[str], dict[str, Any]] | None = None,
                 endpoint: str = DEFAULT_ENDPOINT, token: str | None = None,
                 tokens: TokenBook | Callable[[], TokenBook] | None = None,
                 certificate: Path | None = None, private_key: Path | None = None,
                 ca: Path | None = None, audit: AuditLog | None = None) -> None:
        _import_asyncua()
        self.tokens = check_tokens(token, tokens)
        self.host, self.port = _check_endpoint(endpoint, self.tokens is not None)
        self._tls = load_tls(certificate, private_key, ca)
        self.audit = audit
        self.throttle = Throttle()
        self._endpoint = endpoint
        self._locate = locate
        self._identify = identify
        self._register = register
        self._server: Server | None = None
        self._nodes: dict[str, Any] = {}
        self._executor: ThreadPoolExecutor | None = None
        self._job: str | None = None          # what runs now, for the Busy answer
        self.state = State.READY

    @property
    def encrypted(self) -> bool:
        """Whether the face signs and encrypts (it has a certificate)."""
        return self._tls is not None

    @property
    def endpoint_url(self) -> str:
        """The endpoint, with the port actually bound once started."""
        parts = urlsplit(self._endpoint)
        host = f"[{self.host}]" if ":" in self.host else self.host
        return parts._replace(netloc=f"{host}:{self.port}").geturl()

    async def __aenter__(self) -> OpcUaFace:
        await self.start()
        return self

    async def __aexit__(self, *exc: Any) -> None:
        await self.stop()

    async def start(self) -> None:
        """Build the address space and listen (about 1-2 s: asyncua builds the standard
        address space first)."""
        from photomodel.service._server import is_loopback

        asyncua = _import_asyncua()
        ua = asyncua.ua
        logging.getLogger("asyncua.server.server").addFilter(_START_FILTER)   # once: a set
        iserver = internal_server_class()(
            user_manager=Users(self.tokens, self.throttle, self.audit))
        server = asyncua.Server(iserver=iserver)
        await server.init()
        server.set_server_name("photomodel cell")
        tls = self._tls
        if tls is None:
            await server.set_application_uri(APPLICATION_URI)
            policy = ua.SecurityPolicyType.NoSecurity
            if not is_loopback(self.host):
                _log.warning("OPC UA on %s without a certificate: its traffic, tokens "
                             "included, is not encrypted (give --tls-cert and --tls-key)",
                             self.host)
        else:
            await server.load_certificate(tls.cert_der)
            await server.load_private_key(tls.key_der)
            await server.set_application_uri(tls.application_uri)
            certificates = ClientCertificates(tls.ca, self.audit)
            server.set_certificate_validator(certificates)
            iserver.channel_check = certificates.check_channel
            policy = getattr(ua.SecurityPolicyType, SECURE_POLICY)
            if tls.ca is None:
                _log.warning("OPC UA without a CA to trust (--tls-ca): any client "
                             "certificate is accepted")
        rules = Rules(self.tokens, self.audit)
        server.set_endpoint(self._endpoint)
        server.set_security_policy([policy], permission_ruleset=rules)
        server.set_identity_tokens([ua.UserNameIdentityToken] if self.tokens
                                   else [ua.AnonymousIdentityToken])
        idx = await server.register_namespace(NAMESPACE)
        if idx != 2:
            _log.warning("OPC UA: the nodes are in namespace index %d, not 2 (the "
                         "certificate's application URI %s is their namespace)", idx,
                         server.get_application_uri())
        await self._build(server, idx)
        if self._register is not None:
            rules.register_id = ua.NodeId(f"{OBJECT_NAME}.Register", idx)
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="photomodel-opcua")
        await server.start()
        bound = server.bserver.port if server.bserver is not None else self.port
        self.port = int(bound) if bound else self.port
        self._server = server
        _log.info("OPC UA face listening on %s (%s)", self.endpoint_url,
                  SECURE_POLICY if tls else "no security")

    async def stop(self) -> None:
        """Stop listening; a job in flight finishes in its thread, unanswered."""
        server, self._server = self._server, None
        if server is not None:
            await server.stop()
        if self._executor is not None:
            self._executor.shutdown(wait=False, cancel_futures=True)
            self._executor = None

    # -- the address space ---------------------------------------------------------------

    async def _build(self, server: Server, idx: int) -> None:
        from asyncua import ua

        def nid(name: str) -> ua.NodeId:
            return ua.NodeId(f"{OBJECT_NAME}.{name}", idx)

        obj = await server.nodes.objects.add_object(ua.NodeId(OBJECT_NAME, idx),
                                                    ua.QualifiedName(OBJECT_NAME, idx))
        nan3, nan4 = [math.nan] * 3, [math.nan] * 4
        variables: list[tuple[str, Any, ua.VariantType, int | None, str]] = [
            ("State", State.READY.text, ua.VariantType.String, None,
             "Ready, Busy (a Locate or Identify runs) or Error (the last one failed)"),
            ("StateNumber", State.READY.value, ua.VariantType.UInt32, None,
             "OPC 40100's StateNumber of State: 6 Ready, 7 Busy (SingleExecution), 3 Error"),
            ("ErrorText", "", ua.VariantType.String, None,
             "why State is Error (empty otherwise)"),
            ("LastCallText", "", ua.VariantType.String, None,
             "the last call's Bad answer in words (refused or failed); empty after Good"),
            ("Found", False, ua.VariantType.Boolean, None,
             "whether the last result found a garment (score >= min_score)"),
            ("Model", "", ua.VariantType.String, None, "the model located or identified"),
            ("PositionMm", nan3, ua.VariantType.Double, 3,
             "x, y, z of the model's origin in camera 1's frame, mm (NaN: no pose)"),
            ("QuatWxyz", nan4, ua.VariantType.Double, 4,
             "the model's orientation in camera 1's frame, quaternion w, x, y, z"),
            ("ThetaDeg", math.nan, ua.VariantType.Double, None,
             "in-plane angle of the model's x axis about camera 1's z axis, deg"),
            ("Score", math.nan, ua.VariantType.Double, None, "the result's score in [0, 1]"),
            ("Timestamp", _NO_TIME, ua.VariantType.DateTime, None,
             "when the result's frame was taken (UTC)"),
            ("ResultId", "", ua.VariantType.String, None,
             "the result's id (HTTP /results/{id}); empty while Busy or after a failure"),
        ]
        for name, value, vtype, length, text in variables:
            var = await obj.add_variable(nid(name), ua.QualifiedName(name, idx),
                                         ua.Variant(value, vtype), datatype=vtype.value)
            if length is not None:
                await var.write_value_rank(1)
                await var.write_array_dimensions([length])
            await var.write_attribute(ua.AttributeIds.Description,
                                      ua.DataValue(ua.Variant(ua.LocalizedText(text))))
            self._nodes[name] = var

        def arg(name: str, vtype: ua.VariantType, text: str) -> ua.Argument:
            return ua.Argument(Name=name, DataType=ua.NodeId(vtype.value), ValueRank=-1,
                               ArrayDimensions=[], Description=ua.LocalizedText(text))

        s, b = ua.VariantType.String, ua.VariantType.Boolean
        found = arg("found", b, "whether the garment was found")
        rid = arg("result_id", s, "the result's id (also in ResultId)")
        await obj.add_method(nid("Locate"), ua.QualifiedName("Locate", idx), self._on_locate,
                             [arg("model", s, "the model's name in the library")],
                             [found, rid])
        await obj.add_method(nid("Identify"), ua.QualifiedName("Identify", idx),
                             self._on_identify, [],
                             [found, arg("model", s, "the model identified (empty: none)"), rid])
        await obj.add_method(nid("Reset"), ua.QualifiedName("Reset", idx), self._on_reset,
                             [], [])
        if self._register is not None:
            await obj.add_method(
                nid("Register"), ua.QualifiedName("Register", idx), self._on_register,
                [arg("name", s, "the new model's name; the garment lies in the cameras' view "
                                "on the table, nothing else there")],
                [arg("registered", b, "whether the model was built and added"),
                 arg("model", s, "its name"), rid])

    async def _write(self, **values: Any) -> None:
        from asyncua import ua

        types = {"State": ua.VariantType.String, "StateNumber": ua.VariantType.UInt32,
                 "ErrorText": ua.VariantType.String, "LastCallText": ua.VariantType.String,
                 "Found": ua.VariantType.Boolean, "Model": ua.VariantType.String,
                 "PositionMm": ua.VariantType.Double, "QuatWxyz": ua.VariantType.Double,
                 "ThetaDeg": ua.VariantType.Double, "Score": ua.VariantType.Double,
                 "Timestamp": ua.VariantType.DateTime, "ResultId": ua.VariantType.String}
        assert self._server is not None
        now = datetime.now(UTC)
        for name, value in values.items():    # the server's own write: no session checks
            await self._server.write_attribute_value(
                self._nodes[name].nodeid,
                ua.DataValue(ua.Variant(value, types[name]), SourceTimestamp=now,
                             ServerTimestamp=now))

    async def _enter(self, state: State, error_text: str = "") -> None:
        self.state = state
        await self._write(State=state.text, StateNumber=state.value, ErrorText=error_text)

    # -- the methods -----------------------------------------------------------------------

    async def _on_locate(self, parent: Any, *args: Any) -> Any:
        return await self._call("Locate", args, ["model"])

    async def _on_identify(self, parent: Any, *args: Any) -> Any:
        return await self._call("Identify", args, [])

    async def _on_register(self, parent: Any, *args: Any) -> Any:
        return await self._call("Register", args, ["name"])

    async def _on_reset(self, parent: Any, *args: Any) -> Any:
        from asyncua import ua

        try:
            _check_args("Reset", args, [])
            if self.state is State.BUSY:
                raise _Refused(ua.StatusCodes.BadInvalidState,
                               f"Reset: busy with {self._job}; a search cannot be aborted")
        except _Refused as refused:
            return await self._refuse(refused, len(args))
        if self.state is State.ERROR:
            await self._enter(State.READY)
        await self._write(LastCallText="")
        return []

    async def _call(self, method: str, args: tuple[Any, ...], names: list[str]) -> Any:
        from asyncua import ua

        caller = CALLER.get()
        try:
            if (method == "Register" and self.tokens is not None
                    and (caller is None or caller.credential is None
                         or not allows(caller.credential.role, "admin"))):
                # the ruleset refuses it before: this holds should asyncua call it anyway
                raise _Refused(ua.StatusCodes.BadUserAccessDenied,
                               "Register: needs the admin role")
            values = _check_args(method, args, names)
            if self.state is State.BUSY:
                raise _Refused(ua.StatusCodes.BadInvalidState,
                               f"{method}: busy with {self._job}; call again when State is "
                               "Ready")
        except _Refused as refused:
            return await self._refuse(refused, len(args))
        loop = asyncio.get_running_loop()
        if method == "Locate":
            job = partial(self._locate, values[0])
            self._job = f"Locate({values[0]!r})"
        elif method == "Register":
            assert self._register is not None
            job = partial(self._register, values[0])
            self._job = f"Register({values[0]!r})"
        else:
            job = self._identify
            self._job = "Identify()"
        # Busy, and no stale result to read meanwhile (written without a pause: a client
        # never reads a mix of two results)
        await self._enter(State.BUSY)
        await self._write(Found=False, Model="", PositionMm=[math.nan] * 3,
                          QuatWxyz=[math.nan] * 4, ThetaDeg=math.nan, Score=math.nan,
                          Timestamp=_NO_TIME, ResultId="", LastCallText="")
        context = contextvars.copy_context()        # the cell's audit knows who: ACTOR
        context.run(ACTOR.set, caller_actor(caller, self.tokens is not None))
        try:
            assert self._executor is not None
            answer = await loop.run_in_executor(self._executor, partial(context.run, job))
            outputs = await self._publish(method, answer)
        except Exception as exc:  # noqa: BLE001 - every failure is answered, the server stays
            code, text = _status_of(exc)
            if code == ua.StatusCodes.BadInternalError:
                _log.error("%s failed", self._job, exc_info=exc)
            self._job = None
            await self._enter(State.ERROR, text)
            await self._write(LastCallText=text)
            return _bad(code, text, len(args))
        self._job = None
        await self._enter(State.READY)
        await self._write(LastCallText="")     # a refusal meanwhile was answered before this
        return outputs

    async def _publish(self, method: str, answer: dict[str, Any]) -> list[ua.Variant]:
        """Write ``answer`` into the result variables; the method's output arguments."""
        from asyncua import ua

        found = bool(answer.get("found")) or method == "Register"
        model = answer.get("model") or answer.get("name") or ""
        result_id = str(answer.get("id") or "")
        values = {"Found": found, "Model": str(model),
                  "PositionMm": _numbers(answer.get("position_mm"), 3),
                  "QuatWxyz": _numbers(answer.get("quat_wxyz"), 4),
                  "ThetaDeg": _number(answer.get("theta_deg")),
                  "Score": _number(answer.get("score")),
                  "Timestamp": _frame_time(answer), "ResultId": result_id}
        await self._write(**values)
        outputs = [ua.Variant(found, ua.VariantType.Boolean)]
        if method in ("Identify", "Register"):
            outputs.append(ua.Variant(str(model), ua.VariantType.String))
        outputs.append(ua.Variant(result_id, ua.VariantType.String))
        return outputs

    async def _refuse(self, refused: _Refused, n_args: int) -> Any:
        await self._write(LastCallText=refused.text)
        return _bad(refused.code, refused.text, n_args, refused.argument)


def _check_args(method: str, args: Sequence[Any], names: list[str]) -> list[str]:
    """The String values of ``args`` (one per name); _Refused when there are too few, too
    many, or one is not a String."""
    from asyncua import ua

    if len(args) < len(names):
        raise _Refused(ua.StatusCodes.BadArgumentsMissing,
                       f"{method}: expected {len(names)} argument(s) "
                       f"({', '.join(names)}), got {len(args)}")
    if len(args) > len(names):
        raise _Refused(ua.StatusCodes.BadTooManyArguments,
                       f"{method}: expected {len(names)} argument(s)"
                       + (f" ({', '.join(names)})" if names else "") + f", got {len(args)}")
    values = []
    for i, (name, variant) in enumerate(zip(names, args, strict=True)):
        vtype = getattr(variant, "VariantType", None)
        value = getattr(variant, "Value", None)
        if vtype != ua.VariantType.String or not isinstance(value, str):
            got = "null" if value is None else getattr(vtype, "name", type(variant).__name__)
            if isinstance(value, list):
                got = f"an array of {got}"
            raise _Refused(ua.StatusCodes.BadInvalidArgument,
                           f"{method}: argument {name!r}: expected a String, got {got}", i)
        values.append(value)
    return values


def _bad(code: int, text: str, n_args: int, argument: int | None = None) -> Any:
    """A CallMethodResult with a Bad status; an argument at fault gets BadTypeMismatch and
    the text as its diagnostic (the per-argument slots OPC UA has for it)."""
    from asyncua import ua

    result = ua.CallMethodResult(StatusCode=ua.StatusCode(code))
    if argument is not None:
        result.InputArgumentResults = [
            ua.StatusCode(ua.StatusCodes.BadTypeMismatch if i == argument else
                          ua.StatusCodes.Good) for i in range(n_args)]
        result.InputArgumentDiagnosticInfos = [
            ua.DiagnosticInfo(AdditionalInfo=text if i == argument else None)
            for i in range(n_args)]
    return result


class OpcUaThread:
    """A face served by its own asyncio loop in a daemon thread, beside uvicorn's.

    Examples
    --------
    >>> with OpcUaThread(face) as opcua:            # doctest: +SKIP
    ...     print(opcua.endpoint_url)
    """

    def __init__(self, face: OpcUaFace) -> None:
        self.face = face
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Event | None = None
        self._started = threading.Event()
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="photomodel-opcua",
                                        daemon=True)

    @property
    def endpoint_url(self) -> str:
        return self.face.endpoint_url

    def _run(self) -> None:
        asyncio.run(self._main())

    async def _main(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._stop = asyncio.Event()
        try:
            await self.face.start()
        except BaseException as exc:  # noqa: BLE001 - handed to the thread that started us
            self._error = exc
            self._started.set()
            return
        self._started.set()
        try:
            await self._stop.wait()
        finally:
            await self.face.stop()

    def start(self, timeout_s: float = 60.0) -> OpcUaThread:
        """Start the thread and wait until the face listens; the face's error if it could
        not (a port in use: OSError). A handle already started is returned as it is."""
        if self._thread.ident is not None:
            return self
        self._thread.start()
        if not self._started.wait(timeout_s):
            raise RuntimeError(f"the OPC UA face did not start within {timeout_s:g} s")
        if self._error is not None:
            self._thread.join(timeout=5)
            raise self._error
        return self

    def stop(self, timeout_s: float = 10.0) -> None:
        """Stop the face and its thread (idempotent)."""
        if self._loop is not None and self._stop is not None and self._thread.is_alive():
            self._loop.call_soon_threadsafe(self._stop.set)
        if self._thread.is_alive():
            self._thread.join(timeout=timeout_s)

    def __enter__(self) -> OpcUaThread:
        return self.start()

    def __exit__(self, *exc: Any) -> None:
        self.stop()


def run_opcua_in_thread(face: OpcUaFace, timeout_s: float = 60.0) -> OpcUaThread:
    """Serve ``face`` in a daemon thread with its own event loop; returns once it listens.
    Call ``.stop()`` on the handle to end it."""
    return OpcUaThread(face).start(timeout_s)
