"""The OPC UA face's security on asyncua's own hooks (see :mod:`photomodel.service._opcua`):
the credentials and server certificate checked up front, the user manager (:class:`Users`),
the permission ruleset (:class:`Rules`), the client certificate validator
(:class:`ClientCertificates`) and the internal server that knows each connection's address
and checks the secure channel's certificate (:func:`internal_server_class`)."""

from __future__ import annotations

import contextvars
import functools
import logging
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from photomodel.errors import InputError
from photomodel.service._audit import Actor, AuditLog
from photomodel.service._auth import Credential, Throttle, TokenBook, allows, check_token

if TYPE_CHECKING:
    from cryptography import x509

__all__ = ["CALLER", "PEER", "SECURE_POLICY", "USER", "ClientCertificates", "Login", "Rules",
           "ServerTls", "Users", "caller_actor", "check_tokens", "internal_server_class",
           "load_tls", "record"]

_log = logging.getLogger("photomodel.service.opcua")

USER = "photomodel"
"""The user name a client may give with any token as its password (the only one of earlier
versions); the credential's label is the other."""

SECURE_POLICY = "Basic256Sha256_SignAndEncrypt"
"""The one security policy (asyncua's ``ua.SecurityPolicyType`` name) offered with a
certificate."""


def check_tokens(token: str | None, tokens: TokenBook | Callable[[], TokenBook] | None
                  ) -> Callable[[], TokenBook] | None:
    """What gives the current credentials, or None (no login): ``tokens`` as it is (a
    callable) or wrapped (a book), or ``token`` as one ``admin`` credential with the label
    :data:`USER` (so that user name is the only one, as in earlier versions)."""
    token = None if token is None else check_token(token, "token")
    if token is not None and tokens is not None:
        raise InputError("token", "give token or tokens, not both")
    if token is not None:
        book = TokenBook([Credential("admin", USER, token)])
        return lambda: book
    if tokens is None:
        return None
    if isinstance(tokens, TokenBook):
        fixed = tokens
        tokens = lambda: fixed                      # noqa: E731 - one line
    if not callable(tokens) or not isinstance(book := tokens(), TokenBook):
        raise InputError("tokens", "expected a TokenBook or a callable that returns one")
    if len(book) == 0:
        raise InputError("tokens", "no credential: nobody could log in")
    return tokens


@dataclass(frozen=True)
class ServerTls:
    """The server's certificate and key (DER, as asyncua loads them), the application URI
    its certificate names, and the CA whose client certificates are trusted (None: any)."""

    cert_der: bytes
    key_der: bytes
    application_uri: str
    ca: x509.Certificate | None


def _read_certificate(path: Path, name: str) -> x509.Certificate:
    """The first certificate in ``path`` (PEM, a chain's first, or DER); InputError naming
    the argument and file otherwise."""
    from cryptography import x509

    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise InputError(name, f"{path}: {exc.strerror or exc}") from None
    try:
        if b"-----BEGIN" in data:
            return x509.load_pem_x509_certificates(data)[0]
        return x509.load_der_x509_certificate(data)
    except ValueError:
        raise InputError(name, f"{path}: not an X.509 certificate (PEM or DER)") from None


def load_tls(certificate: Path | None, private_key: Path | None, ca: Path | None
              ) -> ServerTls | None:
    """The checked server certificate, its key and the trusted CA, or None without a
    certificate; InputError for one without the other, a key that is not the certificate's
    or not RSA of 2048 to 4096 bits (Basic256Sha256's range), or an unreadable file."""
    from cryptography import x509
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric import rsa

    if (certificate is None) != (private_key is None):
        raise InputError("certificate" if certificate is None else "private_key",
                         "certificate and private_key go together")
    if certificate is None or private_key is None:
        if ca is not None:
            raise InputError("ca", "trusting client certificates needs the server's own "
                                   "certificate and private_key")
        return None
    cert = _read_certificate(certificate, "certificate")
    try:
        data = Path(private_key).read_bytes()
    except OSError as exc:
        raise InputError("private_key", f"{private_key}: {exc.strerror or exc}") from None
    try:
        key = (serialization.load_pem_private_key(data, None) if b"-----BEGIN" in data
               else serialization.load_der_private_key(data, None))
    except (ValueError, TypeError) as exc:
        raise InputError("private_key", f"{private_key}: not an unencrypted private key "
                                        f"(PEM or DER): {exc}") from None
    if not isinstance(key, rsa.RSAPrivateKey) or not 2048 <= key.key_size <= 4096:
        raise InputError("private_key", f"{private_key}: Basic256Sha256 needs an RSA key of "
                                        "2048 to 4096 bits")
    public = serialization.PublicFormat.SubjectPublicKeyInfo
    if (key.public_key().public_bytes(serialization.Encoding.DER, public)
            != cert.public_key().public_bytes(serialization.Encoding.DER, public)):
        raise InputError("private_key", f"{private_key} is not the key of {certificate}")
    try:
        san = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
        uris = san.get_values_for_type(x509.UniformResourceIdentifier)
    except x509.ExtensionNotFound:
        uris = []
    if not uris:
        raise InputError("certificate", f"{certificate} names no application URI (a "
                                        "URI in its subjectAltName; photomodel certs writes "
                                        "one)")
    key_der = key.private_bytes(serialization.Encoding.DER,
                                serialization.PrivateFormat.TraditionalOpenSSL,
                                serialization.NoEncryption())
    return ServerTls(cert.public_bytes(serialization.Encoding.DER), key_der, uris[0],
                      None if ca is None else _read_certificate(ca, "ca"))


PEER: contextvars.ContextVar[str | None] = contextvars.ContextVar("photomodel_opcua_peer",
                                                                   default=None)
"""The address of the client whose connection is being served: asyncua serves each
connection in a task of its own, and this is set in it when the client creates its session
(:func:`internal_server_class`)."""


@dataclass(frozen=True)
class Login:
    """A session's user, as asyncua keeps it (it reads ``role``: both of ours are asyncua's
    ``UserRole.User``, which may read, browse and call but not change the address space):
    the credential (None: anonymous, no credentials set) and the client's address."""

    role: Any
    name: str | None
    credential: Credential | None
    client: str


CALLER: contextvars.ContextVar[Login | None] = contextvars.ContextVar(
    "photomodel_opcua_caller", default=None)
"""The user of the call being served, set by :meth:`Rules.check_validity` before asyncua
runs the method callback in the same task."""


def caller_actor(caller: Login | None, credentials: bool) -> Actor:
    """The audit's actor of a call: the credential's role and label; without credentials
    (anonymous, local only) ``admin`` as HTTP without a token file."""
    client = caller.client if caller is not None else (PEER.get() or "unknown")
    if caller is not None and caller.credential is not None:
        return Actor(client, caller.credential.role, caller.credential.label, "opcua")
    return Actor(client, None if credentials else "admin", None, "opcua")


def _status_name(code: int) -> str:
    from asyncua import ua

    return str(ua.status_codes.get_name_and_doc(code)[0])


def record(audit: AuditLog | None, action: str, actor: Actor, status: str | None = None,
            detail: str | None = None) -> None:
    if audit is not None:
        audit.write(action, actor=actor, status=status, detail=detail)


@functools.cache
def internal_server_class() -> type:
    """asyncua's InternalServer that sets :data:`PEER` when a client creates a session (the
    user manager is not told who logs in) and, given a ``channel_check``, runs it on the
    secure channel's client certificate at every ActivateSession: asyncua 2.1 lets a
    client activate a session over the unsecured channel it keeps for discovery, whatever
    the endpoints, and its certificate validator sees the certificate the client names in
    CreateSession, not the one whose key holds the channel."""
    from asyncua.server.internal_server import InternalServer

    class FaceInternalServer(InternalServer):      # type: ignore[misc]
        channel_check: Callable[[bytes | None], None] | None = None

        def create_session(self, name: Any, *args: Any, **kwargs: Any) -> Any:
            external = bool(kwargs.get("external"))
            if external and isinstance(name, tuple) and name:
                PEER.set(str(name[0]))           # the connection's (host, port, ...)
            session = super().create_session(name, *args, **kwargs)
            check = self.channel_check
            if external and check is not None:
                activate = session.activate_session

                def checked(params: Any, peer_certificate: bytes | None) -> Any:
                    check(peer_certificate)
                    return activate(params, peer_certificate)

                session.activate_session = checked
            return session

    return FaceInternalServer


class Users:
    """asyncua's user manager: a credential's token as password and its label (or
    :data:`USER`) as user name; anonymous when there are no credentials. Failed logins are
    counted per address by ``throttle`` and audited."""

    def __init__(self, tokens: Callable[[], TokenBook] | None, throttle: Throttle,
                 audit: AuditLog | None) -> None:
        self._tokens = tokens
        self._throttle = throttle
        self._audit = audit

    def get_user(self, iserver: Any, username: str | None = None,
                 password: str | None = None, certificate: Any = None) -> Login | None:
        from asyncua.crypto.permission_rules import UserRole

        client = PEER.get() or "unknown"
        if self._tokens is None:           # only anonymous tokens are offered then
            return Login(UserRole.User, None, None, client)
        given = None if username is None else str(username)[:64]
        nobody = Actor(client, None, given, "opcua")
        wait = self._throttle.retry_after_s(client)
        if wait is not None:
            _log.warning("OPC UA login refused (user %r from %s): too many failed logins",
                         given, client)
            record(self._audit, "refused", nobody, "BadUserAccessDenied",
                    f"login: too many failed logins from {client}; try again in {wait} s")
            return None
        credential = self._tokens().find(password) if password else None
        if credential is None or username not in (credential.label, USER):
            reason = "no token" if not password else "wrong user name or token"
            self._throttle.failed(client)
            _log.warning("OPC UA login refused (user %r from %s): %s", given, client, reason)
            record(self._audit, "login-failed", nobody, "BadUserAccessDenied", reason)
            return None
        record(self._audit, "login",
                Actor(client, credential.role, credential.label, "opcua"), "Good")
        return Login(UserRole.User, credential.label, credential, client)


class Rules:
    """asyncua's permission ruleset, asked before every request of a session: asyncua's
    simple role rules, then (with credentials) the credential still in the book, with its
    current role; a call to ``Register`` (:attr:`register_id`) needs the ``admin`` role.
    Sets :data:`CALLER` for the method callbacks."""

    def __init__(self, tokens: Callable[[], TokenBook] | None, audit: AuditLog | None
                 ) -> None:
        from asyncua import ua
        from asyncua.crypto.permission_rules import SimpleRoleRuleset

        self._base = SimpleRoleRuleset()
        self._tokens = tokens
        self._audit = audit
        self._call = ua.NodeId(ua.ObjectIds.CallRequest_Encoding_DefaultBinary)
        self.register_id: ua.NodeId | None = None

    def check_validity(self, user: Any, action_type_id: Any, body: Any) -> bool:
        if not isinstance(user, Login) or not self._base.check_validity(user, action_type_id,
                                                                         body):
            return False
        login = user
        if self._tokens is not None:
            assert user.credential is not None
            credential = self._tokens().find(user.credential.token)
            if credential is None:               # taken out of the token file meanwhile
                _log.warning("OPC UA request refused (user %r from %s): its token is no "
                             "longer valid", user.name, user.client)
                return False
            login = replace(user, credential=credential)
        if action_type_id != self._call:
            return True
        CALLER.set(login)
        if (login.credential is None or self.register_id is None
                or allows(login.credential.role, "admin")
                or not self._calls_register(body)):
            return True
        _log.warning("OPC UA: Register refused to %r from %s (role %s; it needs the admin "
                     "role)", login.name, login.client, login.credential.role)
        record(self._audit, "refused", caller_actor(login, True), "BadUserAccessDenied",
                "Register")
        return False

    def _calls_register(self, body: Any) -> bool:
        """Whether the CallRequest ``body`` (after its header) calls Register; True when it
        cannot be read (refused: asyncua would not read it either)."""
        from asyncua import ua
        from asyncua.ua.ua_binary import struct_from_binary

        try:
            params = struct_from_binary(ua.CallParameters, body.copy())
        except Exception:  # noqa: BLE001 - any malformed request is refused
            return True
        return any(m.MethodId == self.register_id for m in params.MethodsToCall)


class ClientCertificates:
    """asyncua's certificate validator (called when a client creates its session): asyncua's
    checks of time, URI, key usage and extended key usage (clientAuth), then, with a ``ca``,
    a chain to it; and :meth:`check_channel`, the secure channel's certificate at every
    session activation. A refusal is audited and raised as asyncua's ServiceError."""

    def __init__(self, ca: x509.Certificate | None, audit: AuditLog | None) -> None:
        from asyncua.crypto.validator import CertificateValidator, CertificateValidatorOptions

        options = CertificateValidatorOptions
        self._checks = CertificateValidator(options.EXT_VALIDATION | options.PEER_CLIENT)
        self._ca = ca
        self._audit = audit

    async def __call__(self, cert: x509.Certificate, app_description: Any) -> None:
        from asyncua import ua
        from asyncua.common.utils import ServiceError

        try:
            await self._checks.validate(cert, app_description)
            if self._ca is not None and not self._signed_by_ca(cert):
                raise ServiceError(ua.StatusCodes.BadCertificateUntrusted)
        except ServiceError as exc:
            self._refused(exc.code, f"client certificate {cert.subject.rfc4514_string()}")
            raise

    def check_channel(self, peer_certificate: bytes | None) -> None:
        """Refuse (ServiceError) a session activated over a channel that does not sign and
        encrypt (no client certificate), or, with a ``ca``, whose certificate (the one the
        client proved it holds the key of) the CA did not sign."""
        from asyncua import ua
        from asyncua.common.utils import ServiceError
        from cryptography import x509

        if not peer_certificate:                  # asyncua's None policy: b""
            code, what = ua.StatusCodes.BadSecurityModeRejected, "a session without " \
                f"{SECURE_POLICY} (an unsecured channel)"
        elif self._ca is None:
            return
        else:
            try:
                cert = x509.load_der_x509_certificate(peer_certificate)
            except ValueError:
                cert = None
            if cert is not None and self._signed_by_ca(cert):
                return
            code = ua.StatusCodes.BadCertificateUntrusted
            what = "secure channel certificate " + (
                cert.subject.rfc4514_string() if cert is not None else "(unreadable)")
        self._refused(code, what)
        raise ServiceError(code)

    def _refused(self, code: int, what: str) -> None:
        client = PEER.get() or "unknown"
        status = _status_name(code)
        _log.warning("OPC UA refused %s from %s: %s", what[:200], client, status)
        record(self._audit, "refused", Actor(client, None, None, "opcua"), status,
                what[:200])

    def _signed_by_ca(self, cert: x509.Certificate) -> bool:
        from asyncua.crypto.truststore import TrustStore
        from cryptography import x509

        assert self._ca is not None
        store = x509.verification.Store([self._ca])
        verifier = TrustStore([], []).policy_builder.store(store).build_client_verifier()
        try:
            verifier.verify(cert, [])
        except x509.verification.VerificationError:
            return False
        return True
