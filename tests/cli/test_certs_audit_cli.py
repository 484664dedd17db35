"""``photomodel certs`` and ``photomodel audit`` on real files, run in-process as the other CLI
tests do: what they write and print, and one error line (exit 2) for bad input."""

from __future__ import annotations

import contextlib
import datetime as dt
import io
import ipaddress
import json
import stat
from pathlib import Path

import pytest

from photomodel.cli import main
from photomodel.service._audit import AUDIT_FIELDS, Actor, AuditLog

CERT_FILES = ("ca.pem", "ca.key", "server.pem", "server.key", "client.pem", "client.key")


def _run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _one_error_line(err: str, *words: str) -> None:
    assert err.startswith("photomodel: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err
    for word in words:
        assert word in err, err


# --- certs -----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def certs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """``certs`` run once (RSA keys take a moment): the directory and what it printed."""
    out = tmp_path_factory.mktemp("certs") / "pki"
    buffer = io.StringIO()                  # capsys is per test: stdout caught by hand
    with contextlib.redirect_stdout(buffer):
        code = main(["certs", "--out", str(out), "--host", "cell-7.plant.example",
                     "--host", "10.20.30.40", "--days", "30"])
    assert code == 0
    return out, buffer.getvalue()


def test_certs_writes_six_files_with_private_keys(certs: tuple[Path, str]) -> None:
    out, printed = certs
    assert sorted(p.name for p in out.iterdir()) == sorted(CERT_FILES)
    for name in CERT_FILES:
        mode = stat.S_IMODE((out / name).stat().st_mode)
        if name.endswith(".key"):
            assert mode == 0o600, name
            assert (out / name).read_bytes().startswith(b"-----BEGIN RSA PRIVATE KEY-----")
        else:
            assert mode & 0o077 in (0o044, 0o004, 0o040, 0), name
            assert (out / name).read_bytes().startswith(b"-----BEGIN CERTIFICATE-----")
    for name in CERT_FILES:
        assert str(out / name) in printed
    assert "cell-7.plant.example" in printed and "10.20.30.40" in printed
    assert f"--tls-cert {out / 'server.pem'} --tls-key {out / 'server.key'}" in printed
    assert f"curl --cacert {out / 'ca.pem'}" in printed
    end = (dt.datetime.now(dt.UTC) + dt.timedelta(days=30)).strftime("%Y-%m-%d")
    start_end = (dt.datetime.now(dt.UTC) + dt.timedelta(days=30, hours=-1)).strftime(
        "%Y-%m-%d")
    assert f"valid until {end}" in printed or f"valid until {start_end}" in printed


def test_the_server_certificate_verifies_against_the_ca_and_names_the_hosts(
        certs: tuple[Path, str]) -> None:
    from cryptography import x509
    from cryptography.x509.oid import ExtendedKeyUsageOID

    out, _ = certs
    ca = x509.load_pem_x509_certificate((out / "ca.pem").read_bytes())
    server = x509.load_pem_x509_certificate((out / "server.pem").read_bytes())
    client = x509.load_pem_x509_certificate((out / "client.pem").read_bytes())
    for cert in (server, client):
        cert.verify_directly_issued_by(ca)                 # raises when not signed by the CA
    ca.verify_directly_issued_by(ca)
    assert ca.extensions.get_extension_for_class(x509.BasicConstraints).value.ca
    names = server.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert set(names.get_values_for_type(x509.DNSName)) == {"cell-7.plant.example",
                                                            "localhost"}
    assert set(names.get_values_for_type(x509.IPAddress)) == {
        ipaddress.ip_address("10.20.30.40"), ipaddress.ip_address("127.0.0.1"),
        ipaddress.ip_address("::1")}
    usage = server.extensions.get_extension_for_class(x509.ExtendedKeyUsage).value
    assert ExtendedKeyUsageOID.SERVER_AUTH in usage
    lifetime = server.not_valid_after_utc - server.not_valid_before_utc
    assert lifetime == dt.timedelta(days=30)
    now = dt.datetime.now(dt.UTC)
    assert server.not_valid_before_utc <= now <= server.not_valid_after_utc


def test_the_certificates_verify_with_the_python_ssl_store(certs: tuple[Path, str]) -> None:
    """What a client does: trust ca.pem, check the server's chain and host name."""
    import ssl

    from cryptography import x509
    from cryptography.hazmat.primitives.serialization import load_pem_private_key
    from cryptography.x509.verification import PolicyBuilder, Store

    out, _ = certs
    ca = x509.load_pem_x509_certificate((out / "ca.pem").read_bytes())
    server = x509.load_pem_x509_certificate((out / "server.pem").read_bytes())
    verifier = PolicyBuilder().store(Store([ca])).build_server_verifier(
        x509.DNSName("cell-7.plant.example"))
    chain = verifier.verify(server, [])
    assert chain[-1] == ca
    key = load_pem_private_key((out / "server.key").read_bytes(), password=None)
    assert key.public_key().public_numbers() == server.public_key().public_numbers()
    context = ssl.create_default_context(cafile=str(out / "ca.pem"))
    context.load_cert_chain(out / "server.pem", out / "server.key")   # the pair matches


def test_certs_refuses_to_overwrite_without_force(certs: tuple[Path, str],
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    out, _ = certs
    before = {name: (out / name).read_bytes() for name in CERT_FILES}
    code, stdout, err = _run(capsys, "certs", "--out", out, "--host", "other.example")
    assert code == 2 and stdout == ""
    _one_error_line(err, "exists already", "--force")
    assert {name: (out / name).read_bytes() for name in CERT_FILES} == before
    assert sorted(p.name for p in out.iterdir()) == sorted(CERT_FILES)   # no temporary file


def test_certs_force_replaces_them(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "pki"
    assert _run(capsys, "certs", "--out", out, "--host", "a.example", "--json")[0] == 0
    old = (out / "server.pem").read_bytes()
    code, stdout, _ = _run(capsys, "certs", "--out", out, "--host", "b.example", "--json",
                           "--force")
    assert code == 0 and (out / "server.pem").read_bytes() != old
    paths = json.loads(stdout)
    assert paths == {"ca_cert": str(out / "ca.pem"), "ca_key": str(out / "ca.key"),
                     "server_cert": str(out / "server.pem"),
                     "server_key": str(out / "server.key"),
                     "client_cert": str(out / "client.pem"),
                     "client_key": str(out / "client.key")}
    assert stat.S_IMODE((out / "server.key").stat().st_mode) == 0o600


@pytest.mark.parametrize(("argv", "words"), [
    (("--host", "bad host"), ("--host", "'bad host'")),
    (("--host", ""), ("--host",)),
    (("--host=-leading.dash",), ("--host", "-leading.dash")),
    (("--host", "ok.example", "--days", "0"), ("--days", "1 to 36500")),
    (("--host", "ok.example", "--ca-days", "40000"), ("--ca-days", "36500")),
    (("--host", "ok.example", "--days", "4000"), ("--days", "--ca-days")),
])
def test_certs_bad_options_give_one_line_and_write_nothing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: tuple[str, ...],
        words: tuple[str, ...]) -> None:
    out = tmp_path / "pki"
    code, stdout, err = _run(capsys, "certs", "--out", out, *argv)
    assert code == 2 and stdout == ""
    _one_error_line(err, *words)
    assert not out.exists()


def test_certs_without_cryptography_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    import sys

    monkeypatch.setitem(sys.modules, "cryptography", None)   # import fails
    code, _, err = _run(capsys, "certs", "--out", tmp_path / "pki", "--host", "a.example")
    assert code == 2
    _one_error_line(err, "cryptography", "pip install")
    assert not (tmp_path / "pki").exists()


# --- audit -----------------------------------------------------------------------------------


SHA = "0123456789abcdef" * 4


@pytest.fixture
def trail(tmp_path: Path) -> Path:
    """A library's audit trail (serve's default place) with five events."""
    path = tmp_path / "lib" / "audit" / "audit.jsonl"
    log = AuditLog(path)
    admin = Actor("10.0.0.7", "admin", "alice")
    log.write("login", actor=admin, status=303)
    log.write("register", actor=admin, model="No.3", sha256=SHA, status=201)
    log.write("refused", actor=Actor("10.0.0.99", None, None, "websocket"), status=401,
              detail="/track \x1b[31mred")
    log.write("delete", actor=Actor("10.0.0.8", "admin", "bob", "opcua"), model="No.3",
              sha256=SHA, status="Good")
    log.write("logout", actor=admin, status=303)
    return path


def test_audit_prints_a_table_oldest_first(trail: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = _run(capsys, "audit", "--log", trail)
    assert code == 0 and err == ""
    lines = out.splitlines()
    header = next(line for line in lines if "action" in line)
    for column in ("time (UTC)", "client", "user (role)", "face", "action", "model", "sha256",
                   "status", "detail"):
        assert column in header
    rows = [line for line in lines if "10.0.0." in line]
    assert len(rows) == 5                                   # one line each, no wrapping
    assert [r.split()[3] for r in rows] == ["alice", "alice", "websocket", "bob", "alice"]
    assert "login" in rows[0] and "logout" in rows[4]
    assert "alice (admin)" in rows[1] and "No.3" in rows[1] and "201" in rows[1]
    assert SHA[:12] in rows[1] and SHA[:13] not in rows[1]
    assert "bob (admin)" in rows[3] and "opcua" in rows[3] and "Good" in rows[3]
    assert "\x1b" not in out and "/track \\x1b[31mred" in rows[2]   # shown, not obeyed
    assert lines[-1] == "5 event(s)"
    assert all(line == line.rstrip() for line in lines)


def test_audit_json_prints_the_lines_as_stored(trail: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = _run(capsys, "audit", "--log", trail, "--json")
    assert code == 0
    assert out.encode() == trail.read_bytes()
    assert all(tuple(json.loads(line)) == AUDIT_FIELDS for line in out.splitlines())


def test_audit_models_reads_the_library_trail(trail: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    library = trail.parent.parent
    code, out, _ = _run(capsys, "audit", "--models", library, "--json")
    assert code == 0 and len(out.splitlines()) == 5


def test_audit_filters_by_action_and_last(trail: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    def actions(*argv: str) -> list[str]:
        code, out, _ = _run(capsys, "audit", "--log", trail, "--json", *argv)
        assert code == 0
        return [json.loads(line)["action"] for line in out.splitlines()]

    assert actions("--action", "register", "delete") == ["register", "delete"]
    assert actions("--action", "login", "--action", "logout") == ["login", "logout"]
    assert actions("--last", "2") == ["delete", "logout"]
    assert actions("--action", "login", "logout", "--last", "1") == ["logout"]
    assert actions("--last", "50") == ["login", "register", "refused", "delete", "logout"]
    code, out, _ = _run(capsys, "audit", "--log", trail, "--action", "record")
    assert code == 0 and out.strip() == f"{trail}: no events matching the filters"


def test_audit_since(trail: Path, capsys: pytest.CaptureFixture[str]) -> None:
    lines = trail.read_bytes().splitlines()
    events = [json.loads(line) for line in lines]
    events[0]["time"] = "2020-01-01T10:00:00.000+00:00"
    events[1]["time"] = "2020-01-01T12:00:00.000+00:00"
    trail.write_text("".join(json.dumps(e, separators=(",", ":")) + "\n" for e in events))

    def count(since: str) -> int:
        code, out, err = _run(capsys, "audit", "--log", trail, "--json", "--since", since)
        assert code == 0, err
        return len(out.splitlines())

    assert count("2019-12-31") == 5
    assert count("2020-01-01T11:00") == 4                 # no offset: UTC
    assert count("2020-01-01T13:00:00+02:00") == 4        # 11:00 UTC
    assert count("2020-01-01T12:00:00Z") == 4             # at or after
    assert count("2020-01-02") == 3


def test_audit_reads_rotated_files_first(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "audit.jsonl"
    log = AuditLog(path, max_bytes=4096, keep=5)
    for k in range(60):
        log.write("login", detail=f"{k:03d}")
    assert (tmp_path / "audit.jsonl.1").exists()
    code, out, _ = _run(capsys, "audit", "--log", path, "--json")
    order = [int(json.loads(line)["detail"]) for line in out.splitlines()]
    assert code == 0 and order == list(range(60))


@pytest.mark.parametrize(("argv", "words"), [
    (("--last", "0"), ("--last",)),
    (("--action", "hack"), ("--action", "'hack'", "register")),
    (("--since", "yesterday"), ("--since", "ISO 8601")),
])
def test_audit_bad_options_give_one_line(trail: Path, capsys: pytest.CaptureFixture[str],
                                         argv: tuple[str, ...], words: tuple[str, ...]) -> None:
    code, out, err = _run(capsys, "audit", "--log", trail, *argv)
    assert code == 2 and out == ""
    _one_error_line(err, *words)


def test_audit_missing_trail_gives_one_line(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = _run(capsys, "audit", "--models", tmp_path / "lib")
    assert code == 2 and out == ""
    _one_error_line(err, str(tmp_path / "lib" / "audit" / "audit.jsonl"), "no audit trail")


def test_audit_a_line_that_is_not_json_gives_one_line_and_prints_nothing(
        trail: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with open(trail, "ab") as fh:
        fh.write(b"not json at all\n")
    for extra in ((), ("--json",)):
        code, out, err = _run(capsys, "audit", "--log", trail, *extra)
        assert code == 2 and out == ""
        _one_error_line(err, f"{trail}:6", "not a JSON line")


def test_audit_needs_log_or_models(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as caught:
        main(["audit"])
    assert caught.value.code == 2
    with pytest.raises(SystemExit) as caught:
        main(["audit", "--log", str(tmp_path / "a"), "--models", str(tmp_path)])
    assert caught.value.code == 2
    assert capsys.readouterr().err.count("\n") == 2
