"""The audit trail: an append-only JSON-lines log of every change to the model library, every
login and every refused request, rotated by size; ``photomodel audit`` prints it."""

from __future__ import annotations

import contextvars
import datetime as dt
import hashlib
import json
import logging
import os
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from photomodel._files import append_lines, locked
from photomodel.errors import InputError

__all__ = ["ACTOR", "AUDIT_ACTIONS", "AUDIT_FIELDS", "Actor", "AuditLog", "file_sha256",
           "read_audit"]

log = logging.getLogger("photomodel.service")

AUDIT_FIELDS = ("time", "client", "role", "user", "face", "action", "model", "sha256",
                "status", "detail")
"""Every line's keys, in order (null where they do not apply): ``time`` (UTC, ISO 8601),
``client`` (address), ``role`` and ``user`` (the credential's label), ``face`` (``http``,
``websocket``, ``opcua``), ``action``, ``model`` (name), ``sha256`` (of the model file after a
registration or replacement, before a deletion), ``status`` (the HTTP status, or the OPC UA
status name) and ``detail`` (the path refused, the reason)."""

AUDIT_ACTIONS = ("register", "replace", "delete", "set-scale", "record", "login", "login-failed",
           "logout", "refused")


@dataclass(frozen=True)
class Actor:
    """Who a request comes from: its address, role and credential label, and the face."""

    client: str | None
    role: str | None = None
    user: str | None = None
    face: str = "http"


ACTOR: contextvars.ContextVar[Actor | None] = contextvars.ContextVar("photomodel_actor",
                                                                    default=None)
"""The actor of the request being served (set by the HTTP guard and the OPC UA face; the
service's worker threads run in a copy of the request's context)."""


def file_sha256(path: Path) -> str | None:
    """The SHA-256 of ``path``'s bytes in hex, or None when it cannot be read."""
    digest = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                digest.update(block)
    except OSError:
        return None
    return digest.hexdigest()


class AuditLog:
    """The audit trail at ``path`` (JSON lines), rotated to ``path.1`` ... ``path.<keep>``
    when it would grow past ``max_bytes``.

    Each event is one ``write`` of one line, flushed to disk before :meth:`write` returns
    (but refusals: see :meth:`write`): a crash never loses a line already written, and a
    line cut short by a power cut is dropped at the next write. Processes appending to one
    file take turns (``fcntl``).
    """

    def __init__(self, path: Path, max_bytes: int = 10 << 20, keep: int = 5) -> None:
        if max_bytes < 4096 or keep < 1:
            raise ValueError("max_bytes >= 4096 and keep >= 1 expected")
        self.path = Path(path)
        self.max_bytes, self.keep = max_bytes, keep
        self._lock = threading.Lock()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._lockfile = self.path.with_name(f".{self.path.name}.lock")

    def write(self, action: str, *, actor: Actor | None = None, model: str | None = None,
              sha256: str | None = None, status: int | str | None = None,
              detail: str | None = None, fsync: bool | None = None) -> None:
        """Append one event; ``actor`` defaults to :data:`ACTOR`'s. An event that cannot be
        written is logged as an error (the request it records is not failed by it).
        ``fsync`` defaults to every action but ``refused``: refusals, which a client can send
        by the thousand, are still written at once, safe from a crash of the process, but
        not forced to disk against a power cut."""
        fsync = action != "refused" if fsync is None else fsync
        actor = actor or ACTOR.get() or Actor(None)
        event = {"time": dt.datetime.now(dt.UTC).isoformat(timespec="milliseconds"),
                 "client": actor.client, "role": actor.role, "user": actor.user,
                 "face": actor.face, "action": action, "model": model, "sha256": sha256,
                 "status": status, "detail": detail}
        line = json.dumps(event, ensure_ascii=True, separators=(",", ":")).encode()
        try:
            with self._lock, locked(self._lockfile):
                self._rotate(len(line) + 1)
                append_lines(self.path, [line], fsync=fsync)
        except OSError as exc:
            log.error("audit: cannot write %s: %s", self.path, exc.strerror or exc)

    def _rotate(self, adding: int) -> None:
        try:
            size = self.path.stat().st_size
        except FileNotFoundError:
            return
        if size + adding <= self.max_bytes or size == 0:
            return
        for n in range(self.keep - 1, 0, -1):
            older = self.path.with_name(f"{self.path.name}.{n}")
            if older.exists():
                os.replace(older, self.path.with_name(f"{self.path.name}.{n + 1}"))
        os.replace(self.path, self.path.with_name(f"{self.path.name}.1"))


def read_audit(path: Path, *, rotated: bool = True) -> Iterator[dict[str, Any]]:
    """The events of the audit trail at ``path``, oldest first (with ``rotated``, those of
    ``path.N`` ... ``path.1`` before). InputError on a line that is not an event, naming the
    file and line."""
    path = Path(path)
    files = sorted((p for p in path.parent.glob(f"{path.name}.*")
                    if p.suffix[1:].isdigit()), key=lambda p: -int(p.suffix[1:])) \
        if rotated else []
    if not path.exists() and not files:
        raise InputError(path, "no audit trail here (the service writes it once something "
                               "is logged)")
    for file in [*files, *([path] if path.exists() else [])]:
        try:
            fh = open(file, "rb")
        except OSError as exc:
            raise InputError(file, f"cannot read: {exc.strerror or exc}") from None
        with fh:
            for number, raw in enumerate(fh, start=1):
                if not raw.endswith(b"\n"):
                    break                  # cut short by a power cut: dropped at next write
                try:
                    event = json.loads(raw)
                except ValueError:
                    raise InputError(f"{file}:{number}", "not a JSON line") from None
                if not isinstance(event, dict) or "action" not in event:
                    raise InputError(f"{file}:{number}", "not an audit event")
                yield event
