"""The audit trail (``photomodel.service._audit``): every field written and read back, rotation
by size, a torn last line, processes killed mid-write and processes appending at once."""

from __future__ import annotations

import datetime as dt
import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from photomodel.errors import InputError
from photomodel.service._audit import (
    ACTOR,
    AUDIT_FIELDS,
    Actor,
    AuditLog,
    file_sha256,
    read_audit,
)

SHA = "ab" * 32


def _lines(path: Path) -> list[bytes]:
    return path.read_bytes().splitlines() if path.exists() else []


def test_every_field_is_written_and_read_back(tmp_path: Path) -> None:
    path = tmp_path / "audit" / "audit.jsonl"
    log = AuditLog(path)
    before = dt.datetime.now(dt.UTC)
    log.write("replace", actor=Actor("10.0.0.7", "admin", "alice", "opcua"), model="No.3",
              sha256=SHA, status=201, detail="replaced \u00e9 \x1b[2J")
    log.write("refused")                                 # no actor: every field null
    first, second = list(read_audit(path))
    assert tuple(first) == AUDIT_FIELDS and tuple(second) == AUDIT_FIELDS
    assert {k: v for k, v in first.items() if k != "time"} == {
        "client": "10.0.0.7", "role": "admin", "user": "alice", "face": "opcua",
        "action": "replace", "model": "No.3", "sha256": SHA, "status": 201,
        "detail": "replaced \u00e9 \x1b[2J"}
    stamp = dt.datetime.fromisoformat(first["time"])
    assert stamp.utcoffset() == dt.timedelta(0)
    assert before - dt.timedelta(seconds=1) <= stamp <= dt.datetime.now(dt.UTC)
    assert second["action"] == "refused" and second["face"] == "http"
    assert all(second[k] is None for k in ("client", "role", "user", "model", "sha256",
                                            "status", "detail"))
    raw = path.read_bytes()
    assert raw.isascii() and b"\x1b" not in raw            # escaped: one line, plain ASCII
    assert len(_lines(path)) == 2


def test_the_actor_of_the_request_is_the_default(tmp_path: Path) -> None:
    path = tmp_path / "audit.jsonl"
    log = AuditLog(path)
    token = ACTOR.set(Actor("192.168.1.5", "controller", "plc", "websocket"))
    try:
        log.write("record", status=201)
    finally:
        ACTOR.reset(token)
    (event,) = read_audit(path)
    assert (event["client"], event["role"], event["user"], event["face"]) == (
        "192.168.1.5", "controller", "plc", "websocket")


def test_file_sha256(tmp_path: Path) -> None:
    import hashlib

    path = tmp_path / "model.npz"
    path.write_bytes(b"model bytes" * 1000)
    assert file_sha256(path) == hashlib.sha256(b"model bytes" * 1000).hexdigest()
    assert file_sha256(tmp_path / "missing") is None


def test_rotation_keeps_keep_files_and_reads_oldest_first(tmp_path: Path) -> None:
    path = tmp_path / "audit.jsonl"
    log = AuditLog(path, max_bytes=4096, keep=3)
    for k in range(200):                                 # about 50 kB: many rotations
        log.write("login", actor=Actor("10.0.0.1", "admin", "alice"), detail=f"{k:05d}")
    names = sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith("."))
    assert names == ["audit.jsonl", "audit.jsonl.1", "audit.jsonl.2", "audit.jsonl.3"]
    assert all((tmp_path / n).stat().st_size <= 4096 for n in names)
    order = [int(e["detail"]) for e in read_audit(path)]
    assert order == list(range(order[0], 200))         # oldest first, none missing, ends last
    assert len(order) > 3 * (4096 // 300)              # the rotated files were read
    current = [int(e["detail"]) for e in read_audit(path, rotated=False)]
    assert current == order[-len(current):] and len(current) < len(order)


def test_read_audit_reads_rotated_files_without_the_current_one(tmp_path: Path) -> None:
    path = tmp_path / "audit.jsonl"
    log = AuditLog(path, max_bytes=4096, keep=2)
    for k in range(40):
        log.write("logout", detail=str(k))
    path.unlink()
    order = [int(e["detail"]) for e in read_audit(path)]
    assert order == sorted(order) and order


def test_a_torn_last_line_is_skipped_then_dropped_by_the_next_write(tmp_path: Path) -> None:
    path = tmp_path / "audit.jsonl"
    log = AuditLog(path)
    for k in range(3):
        log.write("register", model=f"m{k}")
    whole = path.read_bytes()
    with open(path, "ab") as fh:                   # a power cut in the middle of a line
        fh.write(b'{"time":"2025-01-01T00:00:00.000+00:00","client":nu')
    assert [e["model"] for e in read_audit(path)] == ["m0", "m1", "m2"]
    log.write("delete", model="m3")
    assert path.read_bytes().startswith(whole)      # every earlier line kept, byte for byte
    assert [e["model"] for e in read_audit(path)] == ["m0", "m1", "m2", "m3"]
    for line in _lines(path):
        json.loads(line)


@pytest.mark.parametrize(("content", "where", "problem"), [
    (b'{"action":"login"}\nnot json\n', ":2", "not a JSON line"),
    (b'{"action":"login"}\n[1, 2]\n', ":2", "not an audit event"),
    (b'{"time":"x"}\n', ":1", "not an audit event"),
    (b"\xff\xfe\n", ":1", "not a JSON line"),
])
def test_a_bad_line_is_named_by_file_and_line(tmp_path: Path, content: bytes, where: str,
                                              problem: str) -> None:
    path = tmp_path / "audit.jsonl"
    path.write_bytes(content)
    with pytest.raises(InputError, match=problem) as caught:
        list(read_audit(path))
    assert caught.value.source == f"{path}{where}"


def test_a_missing_trail_is_an_input_error(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="no audit trail") as caught:
        list(read_audit(tmp_path / "audit.jsonl"))
    assert caught.value.source == str(tmp_path / "audit.jsonl")


def test_audit_log_settings_are_checked(tmp_path: Path) -> None:
    with pytest.raises(ValueError):
        AuditLog(tmp_path / "a.jsonl", max_bytes=100)
    with pytest.raises(ValueError):
        AuditLog(tmp_path / "a.jsonl", keep=0)


# --- processes -------------------------------------------------------------------------------

_WRITER = """
import sys
from pathlib import Path
from photomodel.service._audit import Actor, AuditLog

log = AuditLog(Path(sys.argv[1]), max_bytes=1 << 30)
actor = Actor("10.0.0.1", "admin", sys.argv[2])
count = int(sys.argv[3])
print("ready", flush=True)
if sys.stdin.readline() != "go\\n":
    raise SystemExit(1)
k = 0
while count < 0 or k < count:
    log.write("register", actor=actor, model=f"m{k}", detail="x" * (k * 37 % 3000),
              sha256=f"{k:064x}")
    k += 1
"""


def _writer(path: Path, user: str, count: int) -> subprocess.Popen[str]:
    """A process appending events of ``user`` to ``path`` (``count`` of them, or until
    killed when negative), once it reads ``go``."""
    proc = subprocess.Popen([sys.executable, "-c", _WRITER, str(path), user, str(count)],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline() == "ready\n"
    return proc


def _go(proc: subprocess.Popen[str]) -> None:
    assert proc.stdin is not None
    proc.stdin.write("go\n")
    proc.stdin.flush()


def test_twenty_kills_during_writes_lose_no_written_line(tmp_path: Path) -> None:
    """SIGKILL at random moments, 20 times, each time a fresh process appending to the same
    file: every line parses, and the number of events only grows."""
    path = tmp_path / "audit.jsonl"
    rng = random.Random(49)
    counts = [0]
    for _ in range(20):
        proc = _writer(path, "killed", -1)
        _go(proc)
        time.sleep(rng.uniform(0.005, 0.08))
        os.kill(proc.pid, signal.SIGKILL)
        assert proc.wait(timeout=30) == -signal.SIGKILL
        lines = _lines(path)
        whole = lines if path.read_bytes().endswith(b"\n") else lines[:-1]
        for line in whole:
            event = json.loads(line)
            assert event["user"] == "killed" and len(event["sha256"]) == 64
        assert len(list(read_audit(path))) == len(whole)
        counts.append(len(whole))
    assert counts == sorted(counts) and counts[-1] > 20
    AuditLog(path).write("logout")                      # a later write repairs any torn tail
    for line in _lines(path):
        json.loads(line)
    assert len(_lines(path)) == counts[-1] + 1


def test_two_processes_appending_at_once_interleave_whole_lines(tmp_path: Path) -> None:
    path = tmp_path / "audit.jsonl"
    n = 300
    procs = [_writer(path, user, n) for user in ("first", "second")]
    for proc in procs:
        _go(proc)
    for proc in procs:
        assert proc.wait(timeout=60) == 0
    events = [json.loads(line) for line in _lines(path)]
    assert len(events) == 2 * n
    users = [e["user"] for e in events]
    for user in ("first", "second"):
        mine = [e for e in events if e["user"] == user]
        assert [e["model"] for e in mine] == [f"m{k}" for k in range(n)]
        assert all(e["detail"] == "x" * (k * 37 % 3000) for k, e in enumerate(mine))
    switches = sum(a != b for a, b in zip(users, users[1:], strict=False))
    assert switches >= 1                                 # they did write side by side
