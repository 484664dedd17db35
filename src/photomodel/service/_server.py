"""Running the service: :func:`serve` in the foreground (``photomodel serve``) and
:class:`ServiceThread` in a background thread on a free loopback port (tests, benchmarks,
a Python cell controller that embeds it); either over TLS with :class:`TlsFiles`."""

from __future__ import annotations

import ipaddress
import socket
import ssl
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import uvicorn

from photomodel.errors import InputError
from photomodel.service._app import create_app
from photomodel.service._cell import CellService

__all__ = ["ServiceThread", "TlsFiles", "is_loopback", "serve"]


def is_loopback(host: str) -> bool:
    """Whether ``host`` names this machine only (127.0.0.0/8, ::1, ``localhost``)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


@dataclass(frozen=True)
class TlsFiles:
    """The server's certificate chain and private key (PEM), for HTTPS and WSS."""

    cert: Path
    key: Path

    def check(self) -> None:
        """InputError naming the option when the files cannot serve TLS (unreadable, not
        PEM, a key that does not match the certificate)."""
        from photomodel._limits import read_capped

        for option, path, marker in (("--tls-cert", self.cert, b"CERTIFICATE-----"),
                                     ("--tls-key", self.key, b"PRIVATE KEY-----")):
            if not Path(path).is_file():
                raise InputError(option, f"{path}: no such file")
            text = read_capped(path, option, 1 << 20)
            if b"-----BEGIN " not in text or marker not in text:
                raise InputError(option, f"{path}: not a PEM file with a "
                                         f"{marker[:-5].decode().lower()} (-----BEGIN "
                                         f"{marker.decode()})")
        try:
            ssl.create_default_context(ssl.Purpose.CLIENT_AUTH).load_cert_chain(
                self.cert, self.key)
        except ssl.SSLError as exc:
            raise InputError("--tls-cert", f"{self.cert} with key {self.key}: cannot serve "
                             f"TLS ({exc.reason or exc})") from None
        except OSError as exc:
            raise InputError("--tls-cert", f"{self.cert}: {exc.strerror or exc}") from None

    def uvicorn(self) -> dict[str, str]:
        """uvicorn.Config's keyword arguments for these files."""
        return {"ssl_certfile": str(self.cert), "ssl_keyfile": str(self.key)}


def serve(cell: CellService, host: str = "127.0.0.1", port: int = 8080,
          progress: Callable[[str], None] | None = None, log_level: str = "info",
          tls: TlsFiles | None = None) -> None:
    """Serve ``cell`` until interrupted (uvicorn; the warm-up runs in a thread meanwhile);
    HTTPS and WSS with ``tls``."""
    config = uvicorn.Config(create_app(cell, progress=progress), host=host, port=port,
                            log_level=log_level, timeout_graceful_shutdown=5,
                            server_header=False, **(tls.uvicorn() if tls else {}))
    uvicorn.Server(config).run()


class ServiceThread:
    """The service on a free loopback port in a daemon thread.

    The warm-up compiles kernels that are not cached yet in spawned processes, so a script
    that embeds the service needs the usual ``if __name__ == "__main__":`` guard.

    Examples
    --------
    >>> with ServiceThread(cell) as service:            # doctest: +SKIP
    ...     service.wait_ready()
    ...     httpx.get(service.url + "/health").json()
    """

    def __init__(self, cell: CellService, *, warm: bool = True, log_level: str = "warning",
                 tls: TlsFiles | None = None) -> None:
        self.cell = cell
        self._socket = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._socket.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._socket.bind(("127.0.0.1", 0))
        self.port = self._socket.getsockname()[1]
        self.url = f"{'https' if tls else 'http'}://127.0.0.1:{self.port}"
        config = uvicorn.Config(create_app(cell, warm=warm), log_level=log_level,
                                timeout_graceful_shutdown=2, **(tls.uvicorn() if tls else {}))
        self._server = uvicorn.Server(config)
        self._thread = threading.Thread(target=self._server.run,
                                        kwargs={"sockets": [self._socket]},
                                        name="photomodel-serve", daemon=True)

    def start(self) -> ServiceThread:
        self._thread.start()
        deadline = time.monotonic() + 30
        while not self._server.started:
            if not self._thread.is_alive() or time.monotonic() > deadline:
                raise RuntimeError("the service did not start")
            time.sleep(0.01)
        return self

    def wait_ready(self, timeout_s: float = 600.0) -> None:
        """Block until the cell has warmed up (RuntimeError when it failed or timed out)."""
        deadline = time.monotonic() + timeout_s
        while self.cell.status == "warming":
            if time.monotonic() > deadline:
                raise RuntimeError("the service did not warm up in time")
            time.sleep(0.05)
        if self.cell.status != "ok":
            raise RuntimeError(f"the service failed to warm up: {self.cell.detail}")

    def stop(self) -> None:
        self._server.should_exit = True
        self._thread.join(timeout=10)
        self._socket.close()

    def __enter__(self) -> ServiceThread:
        return self.start()

    def __exit__(self, *exc: Any) -> None:
        self.stop()
