"""``photomodel audit``: print the service's audit trail (what
:class:`photomodel.service._audit.AuditLog` writes), oldest first, rotated files included."""

from __future__ import annotations

import argparse
import datetime as dt
import io
import json
import sys
from collections import deque
from collections.abc import Iterable
from pathlib import Path
from typing import Any

AUDIT_IN_LIBRARY = Path("audit") / "audit.jsonl"
"""Where ``photomodel serve`` writes the trail without ``--audit-log``, relative to
``--models`` (:class:`photomodel.service.ServiceConfig`'s default)."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "audit", help="print the cell service's audit trail",
        description="Print the audit trail of photomodel serve: every change to the model "
                    "library (register, replace, delete, set-scale), every recording, login, "
                    "logout, failed login and refused request, with who sent it (address, "
                    "credential label and role) and through which face. Oldest first, the "
                    "rotated files (FILE.N ... FILE.1) before FILE. A last line cut short by "
                    "a power cut is left out.")
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--log", type=Path, metavar="FILE",
                       help="the audit trail (serve --audit-log)")
    where.add_argument("--models", type=Path, metavar="LIBDIR",
                       help=f"the model library whose trail to print "
                            f"(LIBDIR/{AUDIT_IN_LIBRARY.as_posix()}, serve's default)")
    p.add_argument("--json", action="store_true",
                   help="print the events as stored, one JSON object per line")
    p.add_argument("--action", action="extend", nargs="+", default=None, metavar="A",
                   help="only these actions (repeatable): register, replace, delete, "
                        "set-scale, record, login, login-failed, logout, refused")
    p.add_argument("--last", type=int, default=None, metavar="N",
                   help="only the last N events (after the other filters)")
    p.add_argument("--since", default=None, metavar="ISO-TIME",
                   help="only events at or after this time (ISO 8601, e.g. 2025-03-01 or "
                        "2025-03-01T14:30; UTC unless it names its offset)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from photomodel.cli._options import check_int
    from photomodel.errors import InputError
    from photomodel.service import AUDIT_ACTIONS, read_audit

    if args.last is not None:
        check_int("--last", args.last, 1)
    for action in args.action or ():
        if action not in AUDIT_ACTIONS:
            raise InputError("--action", f"unknown action {action[:40]!r} (expected one of "
                                         f"{', '.join(AUDIT_ACTIONS)})")
    since = None if args.since is None else _utc(args.since, "--since")
    path = args.log if args.log is not None else args.models / AUDIT_IN_LIBRARY
    actions = None if args.action is None else set(args.action)
    events = _select(read_audit(path), path, actions, since, args.last)
    if args.json:
        for event in events:   # as AuditLog writes a line: the same keys, order and escapes
            print(json.dumps(event, ensure_ascii=True, separators=(",", ":")))
        return 0
    if not events:
        filtered = args.action is not None or since is not None
        print(f"{path}: no events{' matching the filters' if filtered else ''}")
        return 0
    _print_table(events)
    return 0


def _utc(text: str, source: str) -> dt.datetime:
    """``text`` (ISO 8601) as an aware time; one without an offset is UTC."""
    from photomodel.errors import InputError

    try:
        moment = dt.datetime.fromisoformat(text.strip())
    except ValueError:
        raise InputError(source, f"{text[:60]!r} is not an ISO 8601 time (e.g. 2025-03-01 or "
                                 "2025-03-01T14:30:00Z)") from None
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=dt.UTC)


def _select(events: Iterable[dict[str, Any]], path: Path, actions: set[str] | None,
            since: dt.datetime | None, last: int | None) -> list[dict[str, Any]]:
    """The events of ``actions`` (None: all) at or after ``since``, the last ``last`` of
    them; all read before any is printed (a bad line prints nothing but its error)."""
    from photomodel.errors import InputError

    kept: deque[dict[str, Any]] = deque(maxlen=last)
    for event in events:
        if actions is not None and event.get("action") not in actions:
            continue
        if since is not None:
            stamp = event.get("time")
            try:
                moment = _utc(str(stamp), "time")
            except InputError:
                raise InputError(path, f"an event's time {str(stamp)[:60]!r} is not an ISO "
                                       "8601 time (--since cannot compare it)") from None
            if moment < since:
                continue
        kept.append(event)
    return list(kept)


def _text(value: object) -> str:
    """``value`` for a table cell: empty for null, control characters escaped (a refused
    request's path comes from the client and must not drive the terminal)."""
    if value is None:
        return ""
    text = value if isinstance(value, str) else json.dumps(value)
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii")
                   for c in text)


def _time(value: object) -> str:
    """A stored time as ``YYYY-MM-DD HH:MM:SS.mmm`` in UTC (as stored when it is no time)."""
    try:
        moment = _utc(str(value), "time")
    except ValueError:
        return _text(value)
    return moment.astimezone(dt.UTC).isoformat(sep=" ", timespec="milliseconds")[:23]


def _who(event: dict[str, Any]) -> str:
    user, role = _text(event.get("user")), _text(event.get("role"))
    return f"{user} ({role})" if user and role else user or (f"({role})" if role else "")


def _print_table(events: list[dict[str, Any]]) -> None:
    """The events as a table on stdout, one row each (no wrapping when piped)."""
    from rich import box
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    table = Table(box=box.SIMPLE, padding=(0, 1, 0, 0), pad_edge=False, show_edge=False)
    for column in ("time (UTC)", "client", "user (role)", "face", "action", "model", "sha256",
                   "status", "detail"):              # in a narrow terminal, cells wrap
        table.add_column(column, overflow="fold", no_wrap=column in ("time (UTC)", "action"))
    for event in events:
        sha = _text(event.get("sha256"))
        table.add_row(*(Text(cell) for cell in (
            _time(event.get("time")), _text(event.get("client")), _who(event),
            _text(event.get("face")), _text(event.get("action")), _text(event.get("model")),
            sha[:12], _text(event.get("status")), _text(event.get("detail")))))
    terminal = sys.stdout.isatty()
    buffer = io.StringIO()
    Console(file=buffer, width=None if terminal else 1000, force_terminal=terminal,
            highlight=False).print(table)
    text = buffer.getvalue()
    if not terminal:                     # piped: no padding at the ends of the lines
        text = "".join(line.rstrip() + "\n" for line in text.splitlines())
    sys.stdout.write(text)
    print(f"{len(events)} event(s)")
