"""Who may do what (``photomodel.service._auth``): the token file, browser sessions, the throttle
on failed authentication and the role each route needs; plain objects, no service."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from photomodel.errors import InputError
from photomodel.service._auth import (
    Credential,
    Sessions,
    Throttle,
    TokenBook,
    TokenFile,
    allows,
    read_tokens,
    required_role,
)

ADMIN = "a" * 16 + "-admin-token"
CONTROL = "c" * 16 + "-controller-token"
OTHER = "o" * 16 + "-other-token"


def _file(tmp_path: Path, text: str | bytes, name: str = "tokens") -> Path:
    path = tmp_path / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return path


# --- read_tokens -----------------------------------------------------------------------------


def test_a_bare_token_is_an_admin(tmp_path: Path) -> None:
    book = read_tokens(_file(tmp_path, f"{ADMIN}\n"))
    assert [(c.role, c.label, c.token) for c in book.credentials] == [("admin", "admin-1",
                                                                       ADMIN)]


def test_roles_labels_and_comments(tmp_path: Path) -> None:
    text = (f"# the cell's tokens\n\n   \n"
            f"controller {CONTROL} plc-line-3\n"
            f"  # indented comment\n"
            f"admin {ADMIN}\n"
            f"controller {OTHER}\n"
            f"{'b' * 20}\n")
    book = read_tokens(_file(tmp_path, text))
    assert [(c.role, c.label) for c in book.credentials] == [
        ("controller", "plc-line-3"), ("admin", "admin-1"), ("controller", "controller-2"),
        ("admin", "admin-2")]
    assert len(book) == 4


def test_the_token_is_not_in_the_credentials_repr(tmp_path: Path) -> None:
    book = read_tokens(_file(tmp_path, f"admin {ADMIN} alice\n"))
    assert ADMIN not in repr(book.credentials[0])


@pytest.mark.parametrize(("text", "line", "words"), [
    (f"# ok\nsupervisor {ADMIN}\n", 2, "unknown role 'supervisor'"),
    (f"admin {ADMIN}\ncontroller short\n", 2, "at least 16"),
    ("tooshort\n", 1, "at least 16"),
    (f"admin {ADMIN}\ncontroller {ADMIN}\n", 2, "token is already"),
    (f"admin {ADMIN} alice\ncontroller {CONTROL} alice\n", 2, "label 'alice' is already"),
    (f"admin {ADMIN} bob\nadmin {CONTROL}\nadmin {OTHER} admin-2\n", 3,
     "label 'admin-2' is already"),
    (f"admin {ADMIN} alice extra\n", 1, "got 4 words"),
    (f"admin {ADMIN} ali/ce\n", 1, "label"),
    (f"admin {'x' * 15}\u00e9xyz\n", 1, "ASCII"),
])
def test_a_bad_line_is_named_by_file_and_line(tmp_path: Path, text: str, line: int,
                                              words: str) -> None:
    path = _file(tmp_path, text)
    with pytest.raises(InputError, match=words) as caught:
        read_tokens(path)
    assert caught.value.source == f"{path}:{line}"
    assert ADMIN not in str(caught.value) and CONTROL not in str(caught.value)


@pytest.mark.parametrize("content", [b"", b"\n\n", b"# only a comment\n"])
def test_a_file_without_tokens_is_refused(tmp_path: Path, content: bytes) -> None:
    path = _file(tmp_path, content)
    with pytest.raises(InputError, match="no token") as caught:
        read_tokens(path)
    assert caught.value.source == str(path)


def test_a_binary_file_is_refused(tmp_path: Path) -> None:
    path = _file(tmp_path, b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\xff\xfe")
    with pytest.raises(InputError, match="not a text file") as caught:
        read_tokens(path)
    assert caught.value.source == str(path)


def test_a_missing_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError) as caught:
        read_tokens(tmp_path / "missing")
    assert str(tmp_path / "missing") in str(caught.value)


def _read_or_refuse(path: Path) -> None:
    try:
        book = read_tokens(path)
    except InputError as exc:
        assert str(path) in str(exc)
        return
    assert isinstance(book, TokenBook) and len(book) >= 1
    for credential in book.credentials:
        assert credential.role in ("controller", "admin")
        assert len(credential.token) >= 16


_fuzz = settings(max_examples=150, deadline=None,
                 suppress_health_check=[HealthCheck.function_scoped_fixture])

_WORDS = st.sampled_from(["admin", "controller", "#", "viewer", ADMIN, CONTROL, "short",
                          "label", "x" * 70, "\x00", "\u00e9" * 20, "a" * 16, " ", "\t"])


@_fuzz
@given(text=st.text(max_size=300))
def test_fuzz_any_text_is_a_book_or_one_input_error(tmp_path: Path, text: str) -> None:
    path = tmp_path / "fuzz-text"
    path.write_bytes(text.encode("utf-8", "surrogatepass"))
    _read_or_refuse(path)


@_fuzz
@given(data=st.binary(max_size=300))
def test_fuzz_any_bytes_are_a_book_or_one_input_error(tmp_path: Path, data: bytes) -> None:
    path = tmp_path / "fuzz-bytes"
    path.write_bytes(data)
    _read_or_refuse(path)


@_fuzz
@given(lines=st.lists(st.lists(_WORDS, max_size=5).map(" ".join), max_size=8))
def test_fuzz_token_like_lines_are_a_book_or_one_input_error(tmp_path: Path,
                                                             lines: list[str]) -> None:
    path = tmp_path / "fuzz-lines"
    path.write_text("\n".join(lines), encoding="utf-8")
    _read_or_refuse(path)


# --- TokenBook -------------------------------------------------------------------------------


def test_find_gives_the_credential_of_a_right_token_and_none_for_a_wrong_one(
        tmp_path: Path) -> None:
    book = read_tokens(_file(tmp_path, f"controller {CONTROL} plc\nadmin {ADMIN} alice\n"))
    found = book.find(CONTROL)
    assert found is not None and (found.role, found.label) == ("controller", "plc")
    found = book.find(ADMIN.encode())
    assert found is not None and (found.role, found.label) == ("admin", "alice")
    assert book.find(OTHER) is None
    assert book.find(ADMIN[:-1]) is None
    assert book.find("") is None


def test_a_single_token_book_is_one_admin() -> None:
    book = TokenBook.single(ADMIN)
    found = book.find(ADMIN)
    assert found is not None and found.role == "admin" and len(book) == 1


# --- TokenFile -------------------------------------------------------------------------------


def _rewrite(path: Path, text: str) -> None:
    """Write ``text`` and move the modification time on (a coarse clock may not)."""
    before = path.stat().st_mtime_ns
    path.write_text(text)
    os.utime(path, ns=(before + 10**9, before + 10**9))


def test_a_token_file_is_read_again_when_it_changes(tmp_path: Path) -> None:
    path = _file(tmp_path, f"admin {ADMIN}\n")
    tokens = TokenFile(path, check_s=0)
    assert tokens.book().find(ADMIN) is not None and tokens.book().find(CONTROL) is None
    _rewrite(path, f"controller {CONTROL}\n")
    book = tokens.book()
    assert book.find(ADMIN) is None
    found = book.find(CONTROL)
    assert found is not None and found.role == "controller"


def test_a_token_file_turned_bad_keeps_the_last_good_book(tmp_path: Path,
                                                          caplog: pytest.LogCaptureFixture
                                                          ) -> None:
    path = _file(tmp_path, f"admin {ADMIN}\n")
    tokens = TokenFile(path, check_s=0)
    _rewrite(path, "superuser short\n")
    with caplog.at_level("ERROR", logger="photomodel.service"):
        assert tokens.book().find(ADMIN) is not None
    assert "kept the last good one" in caplog.text
    path.unlink()                                          # gone: still the last good one
    assert tokens.book().find(ADMIN) is not None
    path.write_text(f"admin {OTHER}\n")                    # good again: read
    os.utime(path, ns=(10**18, 10**18))
    assert tokens.book().find(OTHER) is not None and tokens.book().find(ADMIN) is None


def test_a_token_file_is_not_read_again_within_check_s(tmp_path: Path) -> None:
    path = _file(tmp_path, f"admin {ADMIN}\n")
    tokens = TokenFile(path, check_s=3600)
    _rewrite(path, f"admin {OTHER}\n")
    assert tokens.book().find(ADMIN) is not None


def test_a_bad_token_file_at_the_start_is_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError):
        TokenFile(_file(tmp_path, "nonsense\n"))


# --- Sessions --------------------------------------------------------------------------------


def _book(*lines: str) -> TokenBook:
    credentials = []
    for line in lines:
        role, token, label = line.split()
        credentials.append(Credential(role, label, token))  # type: ignore[arg-type]
    return TokenBook(credentials)


def test_a_session_is_opened_found_and_closed() -> None:
    book = _book(f"admin {ADMIN} alice")
    sessions = Sessions()
    session = sessions.open(book.credentials[0], "10.0.0.7")
    assert session.id != session.csrf and len(session.id) >= 32
    got = sessions.get(session.id, book)
    assert got is session and got.client == "10.0.0.7" and got.credential.label == "alice"
    assert sessions.get("not-a-session", book) is None
    assert sessions.close(session.id) is session
    assert sessions.get(session.id, book) is None and len(sessions) == 0
    assert sessions.close(session.id) is None


def test_an_idle_session_expires() -> None:
    book = _book(f"admin {ADMIN} alice")
    sessions = Sessions(idle_s=0.25)
    idle = sessions.open(book.credentials[0], "c")
    busy = sessions.open(book.credentials[0], "c")
    for _ in range(8):                             # a request now and then keeps it alive
        time.sleep(0.05)
        assert sessions.get(busy.id, book) is busy
    assert sessions.get(idle.id, book) is None
    time.sleep(0.3)
    assert sessions.get(busy.id, book) is None and len(sessions) == 0


def test_a_session_ends_at_max_s_however_busy() -> None:
    book = _book(f"admin {ADMIN} alice")
    sessions = Sessions(idle_s=10.0, max_s=0.3)
    session = sessions.open(book.credentials[0], "c")
    assert sessions.get(session.id, book) is session
    time.sleep(0.35)
    assert sessions.get(session.id, book) is None


def test_a_session_ends_when_its_token_leaves_the_book() -> None:
    book = _book(f"admin {ADMIN} alice", f"controller {CONTROL} plc")
    sessions = Sessions()
    session = sessions.open(book.credentials[0], "c")
    other = sessions.open(book.credentials[1], "c")
    rotated = _book(f"controller {CONTROL} plc", f"admin {OTHER} alice")
    assert sessions.get(session.id, rotated) is None
    assert sessions.get(session.id, book) is None           # ended, not just hidden
    assert sessions.get(other.id, rotated) is other


def test_a_role_changed_in_the_book_applies_to_open_sessions() -> None:
    book = _book(f"admin {ADMIN} alice")
    sessions = Sessions()
    session = sessions.open(book.credentials[0], "c")
    demoted = _book(f"controller {ADMIN} alice")
    got = sessions.get(session.id, demoted)
    assert got is not None and got.credential.role == "controller"
    assert not allows(got.credential.role, "admin")


def test_max_sessions_drops_the_oldest() -> None:
    book = _book(f"admin {ADMIN} alice")
    sessions = Sessions(max_sessions=3)
    opened = [sessions.open(book.credentials[0], f"c{k}") for k in range(5)]
    assert len(sessions) == 3
    assert [sessions.get(s.id, book) is not None for s in opened] == [False, False, True,
                                                                      True, True]


# --- Throttle --------------------------------------------------------------------------------


def test_ten_failures_block_that_client_only_until_the_window_passes() -> None:
    throttle = Throttle(failures=10, window_s=60.0)
    for k in range(9):
        throttle.failed("10.0.0.9", now=100.0 + k)
        assert throttle.retry_after_s("10.0.0.9", now=100.0 + k) is None
    throttle.failed("10.0.0.9", now=109.0)
    assert throttle.retry_after_s("10.0.0.9", now=109.0) == 51       # 100 + 60 - 109
    assert throttle.retry_after_s("10.0.0.9", now=150.5) == 10       # whole seconds, up
    assert throttle.retry_after_s("10.0.0.9", now=159.9) == 1
    assert throttle.retry_after_s("10.0.0.8", now=109.0) is None     # another client
    assert throttle.retry_after_s("10.0.0.9", now=160.0) is None     # the oldest is 60 s old


def test_failures_spread_wider_than_the_window_do_not_block() -> None:
    throttle = Throttle(failures=10, window_s=60.0)
    for k in range(30):
        throttle.failed("slow", now=100.0 + 7.0 * k)                 # 10 span 63 s
        assert throttle.retry_after_s("slow", now=100.0 + 7.0 * k) is None


def test_a_blocked_client_that_keeps_failing_stays_blocked() -> None:
    throttle = Throttle(failures=3, window_s=10.0)
    for t in (0.0, 1.0, 2.0):
        throttle.failed("c", now=t)
    assert throttle.retry_after_s("c", now=2.0) == 8
    throttle.failed("c", now=9.0)                          # the last three: 1, 2, 9
    assert throttle.retry_after_s("c", now=10.5) == 1
    assert throttle.retry_after_s("c", now=12.0) is None


def test_throttle_settings_are_checked() -> None:
    with pytest.raises(ValueError):
        Throttle(failures=0)
    with pytest.raises(ValueError):
        Throttle(window_s=0.0)


# --- required_role ---------------------------------------------------------------------------


@pytest.mark.parametrize(("method", "path", "role"), [
    ("POST", "/models", "admin"),
    ("DELETE", "/models/No.3", "admin"),
    ("POST", "/models/No.3/scale", "admin"),
    ("POST", "/record", "admin"),
    ("POST", "/locate", "controller"),
    ("POST", "/identify", "controller"),
    ("POST", "/trigger/locate", "controller"),
    ("POST", "/trigger/identify", "controller"),
    ("GET", "/models", "controller"),
    ("GET", "/models/No.3", "controller"),
    ("GET", "/results", "controller"),
    ("GET", "/results/abc/overlay.png", "controller"),
    ("GET", "/track", "controller"),             # the WebSocket's path
    ("GET", "/health", "controller"),
])
def test_the_role_each_route_needs(method: str, path: str, role: str) -> None:
    assert required_role(method, path) == role


def test_an_admin_may_do_what_a_controller_may_and_not_the_other_way() -> None:
    assert allows("admin", "controller") and allows("admin", "admin")
    assert allows("controller", "controller") and not allows("controller", "admin")
