"""Certificates for a plant without its own PKI (``photomodel certs``): a self-signed CA, a
server certificate for the cell service (HTTPS, WSS and OPC UA) and a client certificate for
OPC UA clients, all signed by that CA (the ``cryptography`` package)."""

from __future__ import annotations

import datetime as dt
import ipaddress
import re
from dataclasses import dataclass
from pathlib import Path

from photomodel._files import write_atomic
from photomodel.errors import InputError

__all__ = ["APPLICATION_URI", "CLIENT_URI", "CertFiles", "make_certs"]

APPLICATION_URI = "urn:photomodel:cell:server"
"""The OPC UA application URI of the service, in the server certificate's names (not the
face's namespace ``urn:photomodel:cell``: OPC UA puts the application URI at namespace index
1, and the contract keeps the nodes at 2)."""
CLIENT_URI = "urn:photomodel:client"
"""The OPC UA application URI in the client certificate's names."""
RSA_BITS = 2048           # OPC UA's Basic256Sha256 needs RSA keys of 2048 to 4096 bits


@dataclass(frozen=True)
class CertFiles:
    """What :func:`make_certs` wrote (PEM files; the keys readable by their owner only)."""

    ca_cert: Path
    ca_key: Path
    server_cert: Path
    server_key: Path
    client_cert: Path
    client_key: Path


def _check_host(host: str) -> str:
    if ":" in host.strip("[]"):
        try:
            return str(ipaddress.ip_address(host.strip("[]")))
        except ValueError:
            pass
    if not re.fullmatch(r"(?=.{1,253}$)[A-Za-z0-9_*]([A-Za-z0-9_-]{0,62})"
                        r"(\.[A-Za-z0-9_]([A-Za-z0-9_-]{0,62}))*\.?", host):
        raise InputError("--host", f"{host[:60]!r} is neither a host name nor an IP address")
    return host


def _names(hosts: list[str], uri: str) -> list[object]:
    from cryptography import x509

    names: list[object] = []
    for host in dict.fromkeys([*hosts, "localhost", "127.0.0.1", "::1"]):
        try:
            names.append(x509.IPAddress(ipaddress.ip_address(host)))
        except ValueError:
            names.append(x509.DNSName(host))
    names.append(x509.UniformResourceIdentifier(uri))
    return names


def make_certs(out: Path, hosts: list[str], *, days: int = 825, ca_days: int = 3650,
               not_before: dt.datetime | None = None, force: bool = False) -> CertFiles:
    """Write a CA and a server and a client certificate signed by it into ``out``.

    Parameters
    ----------
    out : Path
        Directory (created when missing); ``ca.pem``, ``ca.key``, ``server.pem``,
        ``server.key``, ``client.pem``, ``client.key``.
    hosts : list of str
        Host names and addresses the service is reached by (the server certificate names
        them; ``localhost``, 127.0.0.1 and ::1 are added).
    days, ca_days : int
        Validity of the server and client certificates, and of the CA, in days.
    not_before : datetime, optional
        Start of the validity (default: an hour ago, for clocks a little behind).
    force : bool
        Replace files that exist (otherwise InputError naming the first, nothing written).
    """
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import rsa
    from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

    for option, value in (("--days", days), ("--ca-days", ca_days)):
        if not 1 <= value <= 36500:
            raise InputError(option, f"expected 1 to 36500 days, got {value}")
    hosts = [_check_host(h) for h in hosts]
    if not hosts:
        raise InputError("--host", "name at least one host the service is reached by")
    out = Path(out)
    files = CertFiles(*(out / f for f in ("ca.pem", "ca.key", "server.pem", "server.key",
                                          "client.pem", "client.key")))
    if not force:
        for path in vars(files).values():
            if path.exists():
                raise InputError(path, "exists already (give --force to replace the "
                                       "certificates)")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(out, f"cannot create the directory: {exc.strerror or exc}") from None
    start = not_before or dt.datetime.now(dt.UTC) - dt.timedelta(hours=1)

    def name(common: str) -> x509.Name:
        return x509.Name([x509.NameAttribute(NameOID.ORGANIZATION_NAME, "photomodel cell"),
                          x509.NameAttribute(NameOID.COMMON_NAME, common)])

    ca_key = rsa.generate_private_key(public_exponent=65537, key_size=RSA_BITS)
    ca_name = name("photomodel cell CA")
    ca = (x509.CertificateBuilder().subject_name(ca_name).issuer_name(ca_name)
          .public_key(ca_key.public_key()).serial_number(x509.random_serial_number())
          .not_valid_before(start).not_valid_after(start + dt.timedelta(days=ca_days))
          .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
          .add_extension(x509.KeyUsage(True, False, False, False, False, True, True, False,
                                       False), critical=True)
          .add_extension(x509.SubjectKeyIdentifier.from_public_key(ca_key.public_key()),
                         critical=False)
          .sign(ca_key, hashes.SHA256()))

    def leaf(common: str, san: list[object], usage: list[x509.ObjectIdentifier]
             ) -> tuple[x509.Certificate, rsa.RSAPrivateKey]:
        key = rsa.generate_private_key(public_exponent=65537, key_size=RSA_BITS)
        cert = (x509.CertificateBuilder().subject_name(name(common)).issuer_name(ca_name)
                .public_key(key.public_key()).serial_number(x509.random_serial_number())
                .not_valid_before(start).not_valid_after(start + dt.timedelta(days=days))
                .add_extension(x509.BasicConstraints(ca=False, path_length=None),
                               critical=True)
                .add_extension(x509.KeyUsage(True, True, True, True, False, False, False,
                                             False, False), critical=True)
                .add_extension(x509.ExtendedKeyUsage(usage), critical=False)
                .add_extension(x509.SubjectAlternativeName(san), critical=False)  # type: ignore[arg-type]
                .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()),
                               critical=False)
                .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(
                    ca_key.public_key()), critical=False)
                .sign(ca_key, hashes.SHA256()))
        return cert, key

    both = [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]
    server, server_key = leaf(hosts[0], _names(hosts, APPLICATION_URI), both)
    client, client_key = leaf("photomodel client",
                              [x509.UniformResourceIdentifier(CLIENT_URI)], both)

    def pem(cert: x509.Certificate) -> bytes:
        return cert.public_bytes(serialization.Encoding.PEM)

    def key_pem(key: rsa.RSAPrivateKey) -> bytes:
        return key.private_bytes(serialization.Encoding.PEM,
                                 serialization.PrivateFormat.TraditionalOpenSSL,
                                 serialization.NoEncryption())

    for path, data, mode in ((files.ca_key, key_pem(ca_key), 0o600),
                             (files.server_key, key_pem(server_key), 0o600),
                             (files.client_key, key_pem(client_key), 0o600),
                             (files.ca_cert, pem(ca), 0o644),
                             (files.server_cert, pem(server), 0o644),
                             (files.client_cert, pem(client), 0o644)):
        write_atomic(path, data, mode=mode)
    return files
