"""``photomodel serve``: the resident cell service (HTTP; contract in docs/contracts.md)."""

from __future__ import annotations

import argparse
import sys
from functools import partial
from pathlib import Path
from typing import Any

from photomodel.cli._options import add_stereo_options
from photomodel.errors import InputError


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("serve", help="run the cell service (HTTP) over a model library",
                       description="Keep the calibration, the model library's index and the "
                                   "recently used models, prepared, in memory and answer "
                                   "/locate, /identify and /models over HTTP; the operator "
                                   "page is at /. /health says 'warming' until every kernel is "
                                   "loaded and the library's index read.")
    add_stereo_options(p, pair=False)
    p.add_argument("--models", required=True, type=Path,
                   help="model library directory (created when missing)")
    p.add_argument("--camera", type=Path, default=None,
                   help="model station calibration (needed to register garments)")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to bind (default 127.0.0.1; any other needs --token-file, "
                        "and without --tls-cert a warning)")
    p.add_argument("--port", type=int, default=8080, help="TCP port (default 8080)")
    p.add_argument("--token-file", type=Path, default=None,
                   help="bearer tokens, one per line 'ROLE TOKEN [LABEL]' (ROLE controller "
                        "or admin; a bare TOKEN is an admin); every request must carry one; "
                        "read again when it changes")
    p.add_argument("--tls-cert", type=Path, default=None,
                   help="serve HTTPS and WSS with this certificate chain (PEM; photomodel "
                        "certs makes one); the OPC UA face then signs and encrypts with it")
    p.add_argument("--tls-key", type=Path, default=None,
                   help="the certificate's private key (PEM)")
    p.add_argument("--tls-ca", type=Path, default=None,
                   help="CA certificate whose client certificates the OPC UA face trusts "
                        "(default: ca.pem beside --tls-cert when there is one)")
    p.add_argument("--audit-log", type=Path, default=None,
                   help="the audit trail, JSON lines (default: audit/audit.jsonl in "
                        "--models); photomodel audit prints it")
    p.add_argument("--searches", type=int, default=2,
                   help="searches run at once (default 2; more wait their turn)")
    p.add_argument("--max-upload-mb", type=int, default=32,
                   help="largest request body in MiB (default 32; 413 beyond)")
    p.add_argument("--results-kept", type=int, default=20,
                   help="recent results kept with their overlays (default 20)")
    p.add_argument("--prepared-models", type=int, default=32,
                   help="models kept prepared in memory, about 22 MB each with 640 x 480 "
                        "cameras (default 32; the least recently used is dropped beyond, and "
                        "prepared again, in about 0.1-0.5 s, when next needed)")
    p.add_argument("--threshold-file", type=Path, default=None,
                   help="found threshold (default: the library's threshold.json, else the "
                        "user's)")
    p.add_argument("--source", default=None, metavar="SPEC",
                   help="camera source, for POST /trigger/locate, /trigger/identify and "
                        "/record: sim[:GARMENT][,conveyor=MM_S] (the simulated hand cameras; "
                        "needs the simulated rig's --stereo), replay:DIR (recorded pairs at "
                        "their frame rate, looping), opencv:R,L (two cv2.VideoCapture: "
                        "device numbers, paths, pipelines, video files) or genicam:R,L"
                        "[,cti=PRODUCER] (two GenICam cameras, optional extra genicam); "
                        "opened at start "
                        "(an error stops the start), re-opened by itself after a stop")
    p.add_argument("--max-skew-ms", type=float, default=5.0,
                   help="largest time between a pair's two views, ms (default 5; a pair "
                        "further apart is refused: unsynchronised cameras give wrong poses)")
    p.add_argument("--record-dir", type=Path, default=None,
                   help="where POST /record writes (default: 'recordings' beside --models)")
    p.add_argument("--opcua", type=int, default=None, metavar="PORT",
                   help="also serve the OPC UA face for PLCs on PORT "
                        "(opc.tcp://HOST:PORT/photomodel/, HOST as --host; needs the 'plc' "
                        "extra; with --token-file a client logs in with a token's label, or "
                        "'photomodel', and the token as password; with --tls-cert only "
                        "Basic256Sha256 SignAndEncrypt)")
    p.add_argument("--log-level", default="info",
                   choices=["critical", "error", "warning", "info", "debug"])
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from photomodel.cli._options import check_int

    check_int("--port", args.port, 1, 65535)
    check_int("--searches", args.searches, 1, 64)
    check_int("--max-upload-mb", args.max_upload_mb, 1, 1024)
    check_int("--results-kept", args.results_kept, 1, 1000)
    check_int("--prepared-models", args.prepared_models, 1, 100_000)
    if args.opcua is not None:
        check_int("--opcua", args.opcua, 1, 65535)
    if not (args.max_skew_ms >= 0 and args.max_skew_ms <= 10_000):
        raise InputError("--max-skew-ms", f"expected 0 to 10000 ms, got {args.max_skew_ms:g}")
    if args.source is not None:
        from photomodel.service import parse_source_spec

        parse_source_spec(args.source)     # a bad spec before anything is loaded
    from photomodel.service import (
        CellService,
        ServiceConfig,
        exposure_warning,
        is_loopback,
        read_tokens,
        serve,
    )

    if args.token_file is not None:
        read_tokens(args.token_file)                  # a bad file before anything is loaded
    elif not is_loopback(args.host):
        raise InputError("--host", f"binding to {args.host} (not this machine only) needs "
                                   "--token-file: every request must then carry a token")
    tls = _tls(args)
    config = ServiceConfig(stereo=args.stereo, models=args.models, camera=args.camera,
                           searches=args.searches, results_kept=args.results_kept,
                           max_upload_bytes=args.max_upload_mb << 20,
                           token_file=args.token_file, audit_log=args.audit_log,
                           host=args.host, tls=tls is not None,
                           threshold=args.threshold_file, prepared_models=args.prepared_models,
                           source=args.source, max_skew_ms=args.max_skew_ms,
                           record_dir=args.record_dir)
    from photomodel.service import SourceError

    try:
        cell = CellService(config)
    except SourceError as exc:           # the source named as the option that gave it
        raise InputError(f"--source {exc.source}", exc.problem) from None

    def say(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    shown = f"[{args.host}]" if ":" in args.host else args.host
    say(f"serve: {'https' if tls else 'http'}://{shown}:{args.port}/ (warming up: /health "
        "says 'warming' until ready)")
    warning = exposure_warning(config)
    if warning is not None:
        say(f"serve: warning: {warning}")
    say(f"serve: audit trail {cell.audit.path}")
    if cell.source is not None:
        say(f"serve: camera source {cell.source.name} (POST /trigger/locate, "
            "/trigger/identify, /record)")
    opcua = None
    try:
        if args.opcua is not None:
            opcua = _start_opcua(cell, args.host, args.opcua, cell.tokens, tls, args.tls_ca)
            say(f"serve: OPC UA {opcua.endpoint_url} (PhotomodelVision.Locate, Identify)")
        serve(cell, args.host, args.port, progress=say, log_level=args.log_level, tls=tls)
    finally:
        if opcua is not None:
            opcua.stop()
        cell.close()
    return 0


def _tls(args: argparse.Namespace) -> Any:
    """The checked ``--tls-cert``/``--tls-key`` pair, or None."""
    from photomodel.service import TlsFiles

    if (args.tls_cert is None) != (args.tls_key is None):
        missing = "--tls-key" if args.tls_key is None else "--tls-cert"
        raise InputError(missing, "--tls-cert and --tls-key go together")
    if args.tls_cert is None:
        if args.tls_ca is not None:
            raise InputError("--tls-ca", "needs --tls-cert and --tls-key")
        return None
    tls = TlsFiles(args.tls_cert, args.tls_key)
    tls.check()
    if args.tls_ca is not None and not args.tls_ca.is_file():
        raise InputError("--tls-ca", f"{args.tls_ca}: no such file")
    return tls


def _start_opcua(cell: Any, host: str, port: int, tokens: Any = None, tls: Any = None,
                 ca: Path | None = None, *, certificate: Path | None = None,
                 private_key: Path | None = None, audit: Any = None) -> Any:
    """The OPC UA face over ``cell``'s trigger methods, listening in its own thread.

    ``tokens``: the credentials (a ``TokenBook``, a callable giving the current one such as
    ``cell.tokens``, or one token string as before); ``certificate`` and ``private_key``
    (or ``tls``, the checked ``--tls-cert``/``--tls-key`` pair) make it sign and encrypt;
    ``ca`` (``--tls-ca``; default ``ca.pem`` beside the certificate when there is one) is
    the CA whose client certificates it trusts; ``audit`` defaults to the cell's trail.
    """
    if tls is not None:
        certificate = certificate or tls.cert
        private_key = private_key or tls.key
    if ca is None and certificate is not None and (Path(certificate).parent
                                                   / "ca.pem").is_file():
        ca = Path(certificate).parent / "ca.pem"
    if audit is None:
        audit = getattr(cell, "audit", None)
    token = tokens if isinstance(tokens, str) else None
    try:
        from photomodel.service import OpcUaFace, run_opcua_in_thread

        def locate(model: str) -> dict[str, Any]:   # on the searches' threads: one team
            return cell.threads.call(partial(cell.trigger_locate, model))

        def identify() -> dict[str, Any]:
            return cell.threads.call(cell.trigger_identify)

        def register(name: str) -> dict[str, Any]:
            from photomodel.service import register_from_camera

            return cell.threads.call(partial(register_from_camera, cell, name))

        face = OpcUaFace(locate, identify, register=register, token=token,
                         tokens=None if token is not None else tokens,
                         certificate=certificate, private_key=private_key, ca=ca,
                         audit=audit,
                         endpoint=f"opc.tcp://{f'[{host}]' if ':' in host else host}:{port}"
                                  "/photomodel/")
    except ImportError as exc:
        raise InputError("--opcua", str(exc)) from None
    except InputError as exc:            # the face's argument named as the option giving it
        options = {"certificate": "--tls-cert", "private_key": "--tls-key", "ca": "--tls-ca",
                   "tokens": "--token-file", "token": "--token-file"}
        if exc.source not in options:
            raise
        raise InputError(f"{options[exc.source]} (--opcua)", exc.problem) from None
    try:
        return run_opcua_in_thread(face)
    except OSError as exc:
        raise InputError("--opcua", f"cannot listen on {face.endpoint_url}: "
                                    f"{exc.strerror or exc}") from None
