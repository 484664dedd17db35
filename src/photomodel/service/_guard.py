"""The service's outermost ASGI layer: who is asking (a bearer token or a browser session),
what their role allows, the throttle on failed authentication, the CSRF check of a browser's
changes, the audit of logins and refusals, the metrics and the latency window, and a JSON 500
for anything unforeseen (the service keeps running)."""

from __future__ import annotations

import hmac
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from urllib.parse import parse_qs

from starlette.requests import Request
from starlette.responses import HTMLResponse, JSONResponse, RedirectResponse, Response
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from photomodel.service._audit import ACTOR, Actor, AuditLog
from photomodel.service._auth import (
    Credential,
    Session,
    Sessions,
    Throttle,
    TokenBook,
    allows,
    required_role,
)
from photomodel.service._json import error_response

__all__ = ["CSRF_HEADER", "SESSION_COOKIE", "Guard"]

SESSION_COOKIE = "photomodel_session"
CSRF_HEADER = "X-CSRF-Token"
_UNSAFE = frozenset({"POST", "PUT", "PATCH", "DELETE"})
_LOGIN_PAGE = """<!doctype html><html lang="en"><head><meta charset="utf-8">
<link rel="icon" href="data:,"><title>photomodel cell: log in</title></head>
<body style="font-family: system-ui, sans-serif; margin: 3em">
<h1>photomodel cell</h1><p>This service needs a token (one of those in its --token-file).</p>
<form method="post" action="login"><input name="token" type="password" autofocus size="40"
autocomplete="current-password"> <button type="submit">Open</button>
<span style="color: #b91c1c">{note}</span></form></body></html>"""


async def drain(receive: Receive, cap_bytes: int) -> None:
    """Read and drop what is left of a request body (at most ``cap_bytes``) before an early
    answer: a client still sending when the server closes sees a broken pipe, not the
    answer."""
    total = 0
    while total <= cap_bytes:
        message = await receive()
        if message["type"] != "http.request":
            return
        total += len(message.get("body", b""))
        if not message.get("more_body", False):
            return


def _client(scope: Scope) -> str:
    client = scope.get("client")
    return str(client[0]) if client else "unknown"


def _headers(scope: Scope) -> dict[bytes, bytes]:
    """The request's headers by lower-case name (the last of repeated ones; ``cookie``
    joined)."""
    out: dict[bytes, bytes] = {}
    for key, value in scope.get("headers", []):
        out[key] = out[key] + b"; " + value if key == b"cookie" and key in out else value
    return out


def _cookie(headers: dict[bytes, bytes], name: str) -> str | None:
    for part in headers.get(b"cookie", b"").split(b";"):
        key, _, value = part.strip().partition(b"=")
        if key.decode("latin-1") == name:
            return value.decode("latin-1")
    return None


@dataclass
class _Who:
    """What a request's credentials say: the credential (None: none or wrong), the session
    it came by, and whether a wrong token was presented (a failed authentication)."""

    credential: Credential | None
    session: Session | None = None
    wrong: bool = False


@dataclass
class _Allowed:
    """An allowed request: who it is, and the browser session it came by (None: a bearer
    token, or no authentication)."""

    actor: Actor
    session: Session | None = None


@dataclass
class _Refusal:
    """A refused request: its status, the one-line reason, who it was, extra headers."""

    status: int
    message: str
    actor: Actor
    headers: dict[str, str] = field(default_factory=dict)


class Guard:
    """The outermost layer of the service's ASGI application.

    Parameters
    ----------
    app : ASGI application
        The routes.
    tokens : callable or None
        Returns the current credentials (a :class:`~photomodel.service._auth.TokenFile`'s
        ``book``); None: no authentication (this machine only), every client an admin.
    audit : AuditLog or None
        Where logins, logouts and refused requests are recorded.
    max_body_bytes : int
        What is read and dropped of a refused request's body.
    observe : callable
        ``observe(scope, status, seconds)`` after every HTTP request (metrics).
    sessions, throttle : optional
        Browser sessions and the throttle on failed authentication (defaults as in their
        classes: 8 h idle, 10 failures a minute).
    """

    def __init__(self, app: ASGIApp, *, tokens: Callable[[], TokenBook] | None,
                 audit: AuditLog | None, max_body_bytes: int,
                 observe: Callable[[Scope, int, float], None],
                 sessions: Sessions | None = None, throttle: Throttle | None = None) -> None:
        self.app = app
        self.tokens = tokens
        self.audit = audit
        self.max_body_bytes = max_body_bytes
        self.observe = observe
        self.sessions = sessions or Sessions()
        self.throttle = throttle or Throttle()
        self._told: dict[str, tuple[float, int]] = {}   # 429s logged: (when, left out since)

    # -- who is asking ------------------------------------------------------------------
    def _who(self, scope: Scope, headers: dict[bytes, bytes], book: TokenBook) -> _Who:
        value = headers.get(b"authorization")
        if value is not None:             # the scheme's case is free (RFC 7235)
            scheme, _, token = value.strip().partition(b" ")
            credential = book.find(token.strip()) if scheme.lower() == b"bearer" else None
            return _Who(credential, wrong=credential is None)
        session_id = _cookie(headers, SESSION_COOKIE)
        if session_id:
            session = self.sessions.get(session_id, book)
            if session is not None:
                return _Who(session.credential, session)
            return _Who(None)      # expired or ended: log in again, not a failure
        return _Who(None)

    def _record(self, action: str, actor: Actor, status: int | None = None,
                detail: str | None = None) -> None:
        if self.audit is None:
            return
        if status == 429:              # a flood must not rotate the real events away
            detail = self._quieted(actor.client or "unknown", detail)
            if detail is None:
                return
        self.audit.write(action, actor=actor, status=status, detail=detail)

    def _quieted(self, client: str, detail: str | None) -> str | None:
        """The detail of a 429 to log for ``client`` (its first in a throttle window, with
        the number left out since the last logged), or None (counted, not logged)."""
        now = time.monotonic()
        last_s, untold = self._told.get(client, (-math.inf, 0))
        if now - last_s < self.throttle.window_s:
            self._told[client] = (last_s, untold + 1)
            return None
        self._told[client] = (now, 0)
        if len(self._told) > 10_000:
            self._told = {c: v for c, v in self._told.items()
                          if now - v[0] < self.throttle.window_s}
        more = f" ({untold} more 429s since the last such line)" if untold else ""
        return f"{detail}{more}; further 429s to {client} within {self.throttle.window_s:g} s " \
               "are counted, not logged"

    def _refusal(self, scope: Scope, headers: dict[bytes, bytes], face: str
                 ) -> _Refusal | _Allowed:
        """An allowed request's actor and browser session, or its refusal."""
        client = _client(scope)
        nobody = Actor(client, None, None, face)
        if self.tokens is None:
            return _Allowed(Actor(client, "admin", None, face))
        wait = self.throttle.retry_after_s(client)
        if wait is not None:
            return _Refusal(429, f"too many failed authentications from {client}; try again "
                                 f"in {wait} s", nobody, {"Retry-After": str(wait)})
        who = self._who(scope, headers, self.tokens())
        if who.credential is None:
            if who.wrong:
                self.throttle.failed(client)
            return _Refusal(401, "missing or wrong bearer token (Authorization: Bearer ...)",
                            nobody, {"WWW-Authenticate": "Bearer"})
        credential = who.credential
        actor = Actor(client, credential.role, credential.label, face)
        method = "GET" if face == "websocket" else scope.get("method", "GET")
        needed = required_role(method, scope["path"])
        if not allows(credential.role, needed):
            return _Refusal(403, f"role {credential.role} may not {method} {scope['path']} "
                                 f"(it needs the {needed} role)", actor)
        if who.session is not None and method in _UNSAFE and not hmac.compare_digest(
                headers.get(CSRF_HEADER.lower().encode(), b""), who.session.csrf.encode()):
            return _Refusal(403, f"missing or wrong CSRF token (a browser's {method} carries "
                                 f"the {CSRF_HEADER} header that GET /session gives)", actor)
        return _Allowed(actor, who.session)

    # -- ASGI ---------------------------------------------------------------------------
    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "websocket":
            await self._websocket(scope, receive, send)
        elif scope["type"] == "http":
            await self._http(scope, receive, send)
        else:
            await self.app(scope, receive, send)

    async def _websocket(self, scope: Scope, receive: Receive, send: Send) -> None:
        decided = self._refusal(scope, _headers(scope), "websocket")
        if isinstance(decided, _Allowed):
            ACTOR.set(decided.actor)
            await self.app(scope, receive, send)
            return
        self._record("refused", decided.actor, decided.status,
                     f"{scope['path']}: {decided.message}")
        await receive()                    # the connect event, then refuse (HTTP 403)
        await send({"type": "websocket.close", "code": 1008})

    async def _http(self, scope: Scope, receive: Receive, send: Send) -> None:
        t0 = time.perf_counter()
        status, started = 500, False

        async def tracked(message: Message) -> None:
            nonlocal status, started
            if message["type"] == "http.response.start":
                status, started = message["status"], True
            await send(message)

        try:
            path = scope["path"]
            if path == "/login":
                await self._login(scope, receive, tracked)
            elif path == "/logout":
                await self._logout(scope, receive, tracked)
            else:
                await self._guarded(scope, receive, tracked)
        except Exception:  # noqa: BLE001 - already logged by Starlette; answer, stay up
            if not started:
                await error_response(500, "internal error (see the service's log)")(
                    scope, receive, tracked)
        finally:
            self.observe(scope, status, time.perf_counter() - t0)

    async def _guarded(self, scope: Scope, receive: Receive, send: Send) -> None:
        headers = _headers(scope)
        decided = self._refusal(scope, headers, "http")
        if isinstance(decided, _Allowed):
            ACTOR.set(decided.actor)
            if scope["path"] == "/session":
                await self._session_info(decided)(scope, receive, send)
            else:
                await self.app(scope, receive, send)
            return
        if decided.status == 401 and scope["path"] == "/" and scope.get("method") == "GET":
            await RedirectResponse("login", status_code=303)(scope, receive, send)
            return
        self._record("refused", decided.actor, decided.status,
                     f"{scope.get('method')} {scope['path']}: {decided.message}")
        await drain(receive, self.max_body_bytes)
        await error_response(decided.status, decided.message, decided.headers)(
            scope, receive, send)

    def _session_info(self, allowed: _Allowed) -> Response:
        """``GET /session``: who this is, the role, and a browser session's CSRF token."""
        actor, session = allowed.actor, allowed.session
        return JSONResponse({"user": actor.user, "role": actor.role,
                             "csrf": session.csrf if session else None,
                             "login": self.tokens is not None},
                            headers={"Cache-Control": "no-store"})

    async def _login(self, scope: Scope, receive: Receive, send: Send) -> None:
        """``GET /login``: a form for a token; ``POST /login``: check it, open a session and
        set its cookie (HttpOnly, SameSite=Strict, Secure under TLS), go to the page."""
        request = Request(scope, receive)
        if self.tokens is None:
            await RedirectResponse("./", status_code=303)(scope, receive, send)
            return
        if request.method != "POST":
            await HTMLResponse(_LOGIN_PAGE.format(note=""),
                               headers={"Cache-Control": "no-store"})(scope, receive, send)
            return
        client = _client(scope)
        wait = self.throttle.retry_after_s(client)
        if wait is not None:
            await drain(receive, 4096)
            self._record("refused", Actor(client, None, None, "http"), 429, "POST /login")
            await HTMLResponse(_LOGIN_PAGE.format(note=f"too many failed logins: try again "
                                                       f"in {wait} s"), status_code=429,
                               headers={"Retry-After": str(wait)})(scope, receive, send)
            return
        body = b""
        async for chunk in request.stream():
            body += chunk
            if len(body) > 4096:
                break
        token = parse_qs(body.decode("utf-8", "replace")).get("token", [""])[0].strip()
        credential = self.tokens().find(token) if token else None
        if credential is None:
            self.throttle.failed(client)
            self._record("login-failed", Actor(client, None, None, "http"), 401,
                         "wrong token" if token else "no token")
            await HTMLResponse(_LOGIN_PAGE.format(note="wrong token"), status_code=401)(
                scope, receive, send)
            return
        session = self.sessions.open(credential, client)
        self._record("login", Actor(client, credential.role, credential.label, "http"), 303)
        response = RedirectResponse("./", status_code=303)
        secure = scope.get("scheme") == "https"
        response.set_cookie(SESSION_COOKIE, session.id, httponly=True, samesite="strict",
                            secure=secure)
        await response(scope, receive, send)

    async def _logout(self, scope: Scope, receive: Receive, send: Send) -> None:
        """``/logout``: end the browser's session, clear its cookie, go to the login form."""
        session_id = _cookie(_headers(scope), SESSION_COOKIE)
        session = self.sessions.close(session_id) if session_id else None
        if session is not None:
            credential = session.credential
            self._record("logout", Actor(_client(scope), credential.role, credential.label,
                                         "http"), 303)
        await drain(receive, 4096)
        response = RedirectResponse("login", status_code=303)
        response.delete_cookie(SESSION_COOKIE, httponly=True, samesite="strict",
                               secure=scope.get("scheme") == "https")
        await response(scope, receive, send)
