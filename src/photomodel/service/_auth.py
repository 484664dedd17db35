"""Who may do what: the token file's credentials and roles, browser sessions, and the throttle
on failed authentication. Plain state, no I/O but the token file's reading; the HTTP guard
(:mod:`photomodel.service._guard`) and the OPC UA face use it."""

from __future__ import annotations

import hashlib
import hmac
import logging
import math
import re
import secrets
import threading
import time
from collections import OrderedDict, deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from photomodel.errors import InputError

__all__ = ["ROLES", "Credential", "Role", "Session", "Sessions", "Throttle", "TokenBook",
           "TokenFile", "read_tokens", "required_role"]

log = logging.getLogger("photomodel.service")

Role = Literal["controller", "admin"]
ROLES: tuple[Role, ...] = ("controller", "admin")
"""The roles, each allowed what the one before it is and more: a ``controller`` locates,
identifies, triggers, tracks and reads the library and results; an ``admin`` also registers,
replaces and deletes models and records."""

MIN_TOKEN_CHARS = 16
MAX_TOKENS = 1000

_ADMIN_ROUTES = (("POST", re.compile(r"/models")),
                 ("DELETE", re.compile(r"/models/[^/]+")),
                 ("POST", re.compile(r"/models/[^/]+/scale")),
                 ("POST", re.compile(r"/record")))


def required_role(method: str, path: str) -> Role:
    """The least role that may send ``method`` to ``path``: ``admin`` for what changes the
    library or writes recordings, ``controller`` for everything else."""
    for verb, pattern in _ADMIN_ROUTES:
        if method == verb and pattern.fullmatch(path):
            return "admin"
    return "controller"


def allows(role: Role, needed: Role) -> bool:
    """Whether ``role`` may do what needs ``needed``."""
    return ROLES.index(role) >= ROLES.index(needed)


@dataclass(frozen=True)
class Credential:
    """One token of the token file: its role and a label that names its holder in the audit
    trail (never the token itself)."""

    role: Role
    label: str
    token: str = field(repr=False)


def check_token(token: str, source: object) -> str:
    """``token`` when it can be the service's one token (at least :data:`MIN_TOKEN_CHARS`
    printable characters, no spaces); InputError naming ``source`` otherwise."""
    if len(token) < MIN_TOKEN_CHARS or any(c.isspace() or not c.isprintable() for c in token):
        raise InputError(source, f"expected one token of at least {MIN_TOKEN_CHARS} printable "
                                 "characters without spaces")
    return token


class TokenBook:
    """The credentials of a token file; :meth:`find` compares a token with every one in
    constant time."""

    def __init__(self, credentials: list[Credential]) -> None:
        self.credentials = tuple(credentials)
        self._digests = [(hashlib.sha256(c.token.encode()).digest(), c) for c in credentials]

    @classmethod
    def single(cls, token: str) -> TokenBook:
        """One ``admin`` token (what a token file of one bare token means)."""
        return cls([Credential("admin", "admin", token)])

    def find(self, token: str | bytes) -> Credential | None:
        """The credential of ``token``, or None; every credential is compared (a wrong token
        takes as long as a right one)."""
        digest = hashlib.sha256(token if isinstance(token, bytes) else token.encode()).digest()
        found = None
        for known, credential in self._digests:
            if hmac.compare_digest(known, digest):
                found = credential
        return found

    def __len__(self) -> int:
        return len(self.credentials)


def read_tokens(path: Path) -> TokenBook:
    """The credentials in token file ``path``.

    One credential per line, ``ROLE TOKEN [LABEL]`` (``ROLE`` ``controller`` or ``admin``;
    ``LABEL`` names the holder in the audit trail, default ``ROLE-N``), or a bare ``TOKEN``
    (an ``admin``: the one-token file of earlier versions). Blank lines and lines starting
    with ``#`` are skipped. A token has at least 16 printable characters without spaces;
    tokens and labels are unique. InputError naming the file and line otherwise.
    """
    from photomodel._limits import read_capped

    raw = read_capped(path, "token file", 256 * 1024)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(path, "not a text file (expected lines of 'ROLE TOKEN [LABEL]')") \
            from None
    credentials: list[Credential] = []
    counts = {role: 0 for role in ROLES}
    for number, line in enumerate(text.splitlines(), start=1):
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        where = f"{path}:{number}"
        if len(words) == 1:
            role, token, label = "admin", words[0], None
        elif len(words) <= 3:
            role, token, label = words[0], words[1], (words[2] if len(words) == 3 else None)
        else:
            raise InputError(where, f"expected 'ROLE TOKEN [LABEL]', got {len(words)} words")
        if role not in ROLES:
            raise InputError(where, f"unknown role {role[:40]!r} (expected controller or "
                                    "admin)")
        if len(token) < MIN_TOKEN_CHARS or not token.isprintable() or not token.isascii():
            raise InputError(where, f"a token needs at least {MIN_TOKEN_CHARS} printable "
                                    "ASCII characters without spaces")
        counts[role] += 1
        label = label or f"{role}-{counts[role]}"
        if not re.fullmatch(r"[A-Za-z0-9._@-]{1,64}", label):
            raise InputError(where, f"label {label[:40]!r}: expected 1 to 64 letters, digits "
                                    "or . _ @ -")
        if any(c.token == token for c in credentials):
            raise InputError(where, "this token is already on an earlier line")
        if any(c.label == label for c in credentials):
            raise InputError(where, f"label {label!r} is already on an earlier line")
        credentials.append(Credential(role, label, token))   # type: ignore[arg-type]
        if len(credentials) > MAX_TOKENS:
            raise InputError(path, f"more than {MAX_TOKENS} tokens")
    if not credentials:
        raise InputError(path, "no token in the file (expected lines of 'ROLE TOKEN "
                               "[LABEL]')")
    return TokenBook(credentials)


class TokenFile:
    """A token file read again when it changes (checked at most once a second), so that
    tokens are rotated without a restart: a new token works, a removed one (and its browser
    sessions) stops working. A file that turns bad keeps the last good credentials and is
    logged."""

    def __init__(self, path: Path, check_s: float = 1.0) -> None:
        self.path = Path(path)
        self.check_s = check_s
        self._stamp = self._stat()
        self._book = read_tokens(self.path)
        self._checked = time.monotonic()
        self._lock = threading.Lock()

    def _stat(self) -> tuple[int, int, int] | None:
        try:
            st = self.path.stat()
        except OSError:
            return None
        return st.st_mtime_ns, st.st_size, st.st_ino

    def book(self) -> TokenBook:
        """The current credentials."""
        now = time.monotonic()
        if now - self._checked < self.check_s:
            return self._book
        with self._lock:
            if now - self._checked >= self.check_s:
                self._checked = now
                stamp = self._stat()
                if stamp is not None and stamp != self._stamp:
                    try:
                        self._book = read_tokens(self.path)
                        self._stamp = stamp
                        log.info("serve: token file %s read again (%d tokens)", self.path,
                                 len(self._book))
                    except InputError as exc:
                        self._stamp = stamp            # logged once per change
                        log.error("serve: token file changed but kept the last good one: "
                                  "%s", exc)
        return self._book


@dataclass
class Session:
    """A browser's login: its random id (the cookie), its CSRF token, and the credential it
    logged in with (its token is held here, server-side, never sent back)."""

    id: str
    csrf: str
    credential: Credential
    client: str
    created_s: float
    expires_s: float


class Sessions:
    """Browser sessions by id: expiring after ``idle_s`` without a request (and ``max_s`` in
    all), ended by :meth:`close`, at most ``max_sessions`` (the oldest dropped). Safe to use
    from several threads."""

    def __init__(self, idle_s: float = 8 * 3600.0, max_s: float = 24 * 3600.0,
                 max_sessions: int = 256) -> None:
        self.idle_s, self.max_s, self.max_sessions = idle_s, max_s, max_sessions
        self._items: OrderedDict[str, Session] = OrderedDict()
        self._lock = threading.Lock()

    def open(self, credential: Credential, client: str) -> Session:
        now = time.monotonic()
        session = Session(secrets.token_urlsafe(32), secrets.token_urlsafe(32), credential,
                          client, now, now + self.idle_s)
        with self._lock:
            self._items[session.id] = session
            while len(self._items) > self.max_sessions:
                self._items.popitem(last=False)
        return session

    def get(self, session_id: str, book: TokenBook) -> Session | None:
        """The live session ``session_id`` (its expiry moved on), or None: unknown, expired,
        or its token no longer in ``book`` (then it ends). Its credential is the book's
        current one (a role changed in the file applies at once)."""
        now = time.monotonic()
        with self._lock:
            session = self._items.get(session_id)
            if session is None:
                return None
            credential = book.find(session.credential.token)
            if now >= session.expires_s or credential is None:
                del self._items[session_id]
                return None
            session.credential = credential
            session.expires_s = min(now + self.idle_s, session.created_s + self.max_s)
            return session

    def close(self, session_id: str) -> Session | None:
        with self._lock:
            return self._items.pop(session_id, None)

    def __len__(self) -> int:
        return len(self._items)


class Throttle:
    """Failed authentication per client: from ``failures`` failures within ``window_s``
    seconds, the client is refused (HTTP 429) until the oldest of them is ``window_s`` old.
    Other clients are not affected. At most ``max_clients`` are remembered (the longest
    quiet forgotten first)."""

    def __init__(self, failures: int = 10, window_s: float = 60.0,
                 max_clients: int = 10_000) -> None:
        if failures < 1 or window_s <= 0:
            raise ValueError("failures >= 1 and window_s > 0 expected")
        self.failures, self.window_s, self.max_clients = failures, window_s, max_clients
        self._seen: OrderedDict[str, deque[float]] = OrderedDict()
        self._lock = threading.Lock()

    def retry_after_s(self, client: str, now: float | None = None) -> int | None:
        """Whole seconds until ``client`` may try again, or None when it may now."""
        now = time.monotonic() if now is None else now
        with self._lock:
            times = self._seen.get(client)
            if times is None or len(times) < self.failures:
                return None
            wait = times[0] + self.window_s - now
            if wait <= 0:
                return None
            return max(1, math.ceil(wait))

    def failed(self, client: str, now: float | None = None) -> None:
        """Count one failed authentication of ``client``."""
        now = time.monotonic() if now is None else now
        with self._lock:
            times = self._seen.pop(client, None) or deque(maxlen=self.failures)
            times.append(now)
            self._seen[client] = times
            while len(self._seen) > self.max_clients:
                self._seen.popitem(last=False)
