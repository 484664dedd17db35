"""``photomodel certs``: a CA and the service's and an OPC UA client's certificates, for a plant
without its own PKI (the work is :func:`photomodel.service.make_certs`)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from photomodel.service import CertFiles


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "certs", help="make a CA and TLS certificates for photomodel serve",
        description="Write a self-signed CA (ca.pem, ca.key), a server certificate for the "
                    "cell service (server.pem, server.key: HTTPS, WSS and the OPC UA face) "
                    "naming the hosts given (and localhost, 127.0.0.1, ::1) and a client "
                    "certificate for OPC UA clients (client.pem, client.key), all signed by "
                    "the CA, into DIR. Keys are readable by their owner only. Start the "
                    "service with --tls-cert DIR/server.pem --tls-key DIR/server.key; clients "
                    "trust DIR/ca.pem. Keep ca.key off the cell: whoever holds it can make "
                    "certificates the clients trust.")
    p.add_argument("--out", required=True, type=Path, metavar="DIR",
                   help="directory for the six PEM files (created when missing)")
    p.add_argument("--host", required=True, action="append", metavar="NAME",
                   help="a host name or IP address the service is reached by (repeat for "
                        "more; the first is the server certificate's common name)")
    p.add_argument("--days", type=int, default=825,
                   help="validity of the server and client certificates in days (default "
                        "825, the most browsers accept)")
    p.add_argument("--ca-days", type=int, default=3650,
                   help="validity of the CA in days (default 3650)")
    p.add_argument("--force", action="store_true",
                   help="replace certificates already in DIR (otherwise refused, nothing "
                        "written)")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object of the paths written")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from photomodel.cli._options import check_int
    from photomodel.errors import InputError

    check_int("--days", args.days, 1, 36500)
    check_int("--ca-days", args.ca_days, 1, 36500)
    if args.days > args.ca_days:
        raise InputError("--days", f"{args.days} days outlast the CA's {args.ca_days} "
                                   "(--ca-days): clients stop trusting the server when the "
                                   "CA expires")
    try:
        import cryptography  # noqa: F401
    except ImportError:
        raise InputError("certs", "needs the Python package 'cryptography' (pip install "
                                  "'cryptography>=42')") from None
    from photomodel.service import make_certs

    files = make_certs(args.out, list(args.host), days=args.days, ca_days=args.ca_days,
                       force=args.force)
    if args.json:
        print(json.dumps({key: str(path) for key, path in vars(files).items()}))
        return 0
    print(_report(files))
    return 0


def _report(files: CertFiles) -> str:
    """What was written, for whom and until when, and how to use it."""
    from cryptography import x509

    def cert(path: Path) -> x509.Certificate:
        return x509.load_pem_x509_certificate(path.read_bytes())

    def until(c: x509.Certificate) -> str:
        return f"valid until {c.not_valid_after_utc:%Y-%m-%d %H:%M} UTC"

    ca, server, client = cert(files.ca_cert), cert(files.server_cert), cert(files.client_cert)
    names = server.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    hosts = [str(n.value) for n in names
             if isinstance(n, x509.DNSName | x509.IPAddress)]
    width = max(len(str(p)) for p in vars(files).values())
    rows = [(files.ca_cert, f"CA certificate, {until(ca)}: clients trust this one"),
            (files.ca_key, "CA private key (owner only): signs certificates, keep it off "
                           "the cell"),
            (files.server_cert, f"server certificate for {', '.join(hosts)}, {until(server)}"),
            (files.server_key, "server private key (owner only)"),
            (files.client_cert, f"OPC UA client certificate, {until(client)}"),
            (files.client_key, "client private key (owner only)")]
    host = hosts[0]
    shown = f"[{host}]" if ":" in host else host
    return "\n".join([
        *(f"wrote {str(path):<{width}}  {what}" for path, what in rows),
        f"start the service with: photomodel serve ... --tls-cert {files.server_cert} "
        f"--tls-key {files.server_key}",
        f"clients must trust {files.ca_cert}, e.g. curl --cacert {files.ca_cert} "
        f"https://{shown}:8080/health",
    ])
