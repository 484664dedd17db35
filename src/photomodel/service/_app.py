"""The cell service's HTTP interface (Starlette): routes, bounded uploads, JSON errors,
Prometheus metrics; who may ask is :mod:`photomodel.service._guard`'s. The work itself is
:class:`CellService`'s, run off the event loop in worker threads (``searches`` at once)."""

from __future__ import annotations

import contextlib
import math
import re
import threading
from collections.abc import AsyncIterator, Callable, Iterator
from importlib import resources
from typing import Any

import anyio
import anyio.to_thread
from prometheus_client import CollectorRegistry, Counter, Gauge, Histogram, generate_latest
from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily, Metric
from prometheus_client.exposition import CONTENT_TYPE_LATEST
from prometheus_client.registry import Collector
from starlette.applications import Starlette
from starlette.datastructures import FormData, UploadFile
from starlette.exceptions import HTTPException
from starlette.formparsers import MultiPartException
from starlette.requests import ClientDisconnect, Request
from starlette.responses import Response
from starlette.routing import Route, WebSocketRoute
from starlette.types import ASGIApp, Message, Scope

from photomodel.errors import InputError, PhotomodelError
from photomodel.service._cell import CellService, Conflict, NotFound, Unavailable
from photomodel.service._guard import Guard, drain
from photomodel.service._json import JSONAnswer as _JSON
from photomodel.service._json import error_response as _error
from photomodel.service._json import finite as _finite
from photomodel.service._source import SourceError
from photomodel.service._track_socket import track_endpoint

__all__ = ["create_app"]

_STATUS = {NotFound: 404, Conflict: 409, Unavailable: 503, SourceError: 503}
_LATENCY_BUCKETS_S = (0.01, 0.02, 0.03, 0.05, 0.075, 0.1, 0.15, 0.2, 0.3, 0.5, 0.75, 1.0, 2.0,
                      5.0, 10.0, 30.0)


class _TooLarge(Exception):
    """A request body over the configured bound."""


def _endpoint(path: str) -> str:
    """A route label with bounded values (ids and names replaced) for metrics."""
    parts = [p for p in path.split("/") if p]
    if not parts:
        return "/"
    head = parts[0]
    if head == "models" and len(parts) >= 2:
        return "/models/{name}" + ("/preview.png" if len(parts) > 2 else "")
    if head == "results" and len(parts) >= 2:
        return "/results/{id}" + ("/overlay.png" if len(parts) > 2 else "")
    if head == "trigger" and parts[1:] in (["locate"], ["identify"]):
        return f"/trigger/{parts[1]}"
    known = {"health", "models", "locate", "identify", "results", "metrics", "stats", "static",
             "track", "record", "camera", "login", "logout", "session"}
    return f"/{head}" if head in known else "other"


class _Metrics:
    """The service's Prometheus metrics, in a registry of its own."""

    def __init__(self, cell: CellService) -> None:
        self.registry = CollectorRegistry()
        self.requests = Counter("photomodel_requests", "HTTP requests by endpoint and status",
                                ["endpoint", "method", "status"], registry=self.registry)
        self.errors = Counter("photomodel_errors", "HTTP answers with a 4xx or 5xx status",
                              ["endpoint", "status"], registry=self.registry)
        self.latency = Histogram("photomodel_request_seconds",
                                 "Wall time of a request, by endpoint", ["endpoint"],
                                 buckets=_LATENCY_BUCKETS_S, registry=self.registry)
        self.in_flight = Gauge("photomodel_searches_in_flight",
                               "Searches and registrations running now",
                               registry=self.registry)
        models = Gauge("photomodel_models", "Models in the library", registry=self.registry)
        models.set_function(cell.model_count)
        ready = Gauge("photomodel_ready", "1 when warmed up and serving",
                      registry=self.registry)
        ready.set_function(lambda: 1.0 if cell.status == "ok" else 0.0)
        self.registry.register(_PreparedCollector(cell))


class _PreparedCollector(Collector):
    """The prepared models' counts (:meth:`CellService.prepared_stats`), read at each
    scrape."""

    def __init__(self, cell: CellService) -> None:
        self.cell = cell

    def collect(self) -> Iterator[Metric]:
        stats = self.cell.prepared_stats()
        prepared, made, evicted = ((stats.prepared, stats.misses, stats.evicted)
                                   if stats is not None else (0, 0, 0))
        yield GaugeMetricFamily("photomodel_prepared_models",
                                "Models prepared in memory now (at most --prepared-models)",
                                value=prepared)
        yield CounterMetricFamily("photomodel_model_preparations",
                                  "Models loaded and prepared (first use after start or "
                                  "eviction, registrations, warm-up)", value=made)
        yield CounterMetricFamily("photomodel_prepared_evictions",
                                  "Prepared models dropped to stay within --prepared-models",
                                  value=evicted)


async def _body(request: Request, limit: int) -> bytes:
    """The request's body, at most ``limit`` bytes (413 beyond; the rest is read and
    dropped first)."""
    chunks, total, more = [], 0, True
    while more:
        message = await request.receive()
        if message["type"] == "http.disconnect":
            raise ClientDisconnect()
        chunk, more = message.get("body", b""), message.get("more_body", False)
        total += len(chunk)
        if total > limit:
            if more:
                await drain(request.receive, limit)
            raise _TooLarge()
        chunks.append(chunk)
    return b"".join(chunks)


async def _form(request: Request, limit: int) -> FormData:
    """The request's multipart form, its body read up to ``limit`` bytes (413 beyond; what
    the client still sends is read and dropped first, up to twice the bound)."""
    size = request.headers.get("content-length")
    if size is not None and size.isdigit() and int(size) > limit:
        await drain(request.receive, 2 * limit)
        raise _TooLarge()
    ctype = request.headers.get("content-type", "")
    if not ctype.startswith("multipart/form-data"):
        await drain(request.receive, limit)
        raise InputError("request", "expected a multipart/form-data body (files and fields)")
    body = await _body(request, limit)
    sent = False

    async def replay() -> Message:
        nonlocal sent
        if sent:
            return {"type": "http.disconnect"}
        sent = True
        return {"type": "http.request", "body": body, "more_body": False}

    try:
        return await Request(request.scope, replay).form(max_files=8, max_fields=16)
    except MultiPartException as exc:
        raise InputError("request", f"malformed multipart body ({exc.message})") from None


async def _file(form: FormData, name: str) -> bytes:
    value = form.get(name)
    if not isinstance(value, UploadFile):
        raise InputError(name, "missing file (send it as a multipart file field)")
    data = await value.read()
    if not data:
        raise InputError(name, "empty file")
    return data


def _field(form: FormData, name: str, required: bool = False) -> str | None:
    value = form.get(name)
    if value is None or value == "":
        if required:
            raise InputError(name, "missing field")
        return None
    if not isinstance(value, str):
        raise InputError(name, "expected a text field, got a file")
    return value


def _seed(form: FormData) -> int | None:
    text = _field(form, "seed")
    if text is None:
        return None
    if not re.fullmatch(r"\d{1,10}", text.strip()) or int(text) > 2**32 - 1:
        raise InputError("seed", f"expected an integer from 0 to 4294967295, got {text!r}")
    return int(text)


def _float(form: FormData, name: str) -> float | None:
    text = _field(form, name)
    if text is None:
        return None
    try:
        value = float(text)
    except ValueError:
        raise InputError(name, f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise InputError(name, f"expected a finite number, got {text!r}")
    return value


def _bool(form: FormData, name: str) -> bool:
    text = (_field(form, name) or "false").strip().lower()
    if text not in ("true", "false", "1", "0", "yes", "no"):
        raise InputError(name, f"expected true or false, got {text!r}")
    return text in ("true", "1", "yes")


def _static(name: str) -> bytes:
    return resources.files("photomodel.service").joinpath("static", name).read_bytes()


_STATIC_TYPES = {"app.js": "text/javascript; charset=utf-8",
                 "style.css": "text/css; charset=utf-8"}


def _exception_handlers(limit: int) -> dict[Any, Callable[..., Any]]:
    """Every error as a JSON answer: the library's errors by kind (400, 404, 409, 503 with
    ``Retry-After``), Starlette's, 413 over ``limit`` bytes, 400 for a client gone, 500."""

    async def on_photomodel_error(request: Request, exc: Exception) -> Response:
        status = _STATUS.get(type(exc), 400)
        headers = {"Retry-After": "5"} if status == 503 else None
        return _error(status, str(exc), headers)

    async def on_http(request: Request, exc: Exception) -> Response:
        assert isinstance(exc, HTTPException)
        return _error(exc.status_code, exc.detail, dict(exc.headers or {}))

    async def on_too_large(request: Request, exc: Exception) -> Response:
        return _error(413, f"request body larger than the {limit >> 20} MiB this service "
                           "accepts (--max-upload-mb)")

    async def on_disconnect(request: Request, exc: Exception) -> Response:
        return _error(400, "the client closed the connection before the body was sent")

    async def on_internal(request: Request, exc: Exception) -> Response:
        return _error(500, "internal error (see the service's log)")

    return {PhotomodelError: on_photomodel_error, HTTPException: on_http,
            _TooLarge: on_too_large, ClientDisconnect: on_disconnect, Exception: on_internal}


def _library_routes(cell: CellService, work: Callable[..., Any], limit: int) -> list[Route]:
    """``/models`` and ``/results`` (imported here: that module uses this one's helpers)."""
    from photomodel.service._library_routes import library_routes

    return library_routes(cell, work, limit)


def _source_routes(cell: CellService, work: Callable[..., Any]) -> list[Route]:
    """The camera source's routes (imported here: that module uses this one's helpers)."""
    from photomodel.service._trigger import trigger_routes

    return trigger_routes(cell, work)


def _pair_routes(cell: CellService, work: Callable[..., Any], limit: int) -> list[Route]:
    """``/locate`` and ``/identify`` (imported here: that module uses this one's helpers)."""
    from photomodel.service._pair_routes import pair_routes

    return pair_routes(cell, work, limit)


def create_app(cell: CellService, *, warm: bool = True,
               progress: Callable[[str], None] | None = None) -> ASGIApp:
    """The ASGI application of ``cell`` (serve it with uvicorn).

    Parameters
    ----------
    cell : CellService
    warm : bool
        Start :meth:`CellService.warm` in a thread at start-up (``/health`` says
        ``warming`` until it is done).
    progress : callable, optional
        Receives the warm-up's progress lines.
    """
    limiter = anyio.CapacityLimiter(cell.searches)
    metrics = _Metrics(cell)
    limit = cell.config.max_upload_bytes
    page = _static("index.html")

    async def work(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        limiter.total_tokens = cell.searches       # one at a time after a workqueue check
        async with limiter:
            metrics.in_flight.inc()
            try:
                return await cell.threads.run(lambda: fn(*args, **kwargs))
            finally:
                metrics.in_flight.dec()

    async def index(request: Request) -> Response:
        return Response(page, media_type="text/html; charset=utf-8",
                        headers={"Cache-Control": "no-store"})

    async def static(request: Request) -> Response:
        name = request.path_params["name"]
        if name not in _STATIC_TYPES:
            raise NotFound("static", f"no file {name!r}")
        return Response(_static(name), media_type=_STATIC_TYPES[name])

    async def health(request: Request) -> Response:
        return _JSON(cell.health())

    async def stats(request: Request) -> Response:
        return _JSON({"latency": cell.latencies.summary(), "health": cell.health()})

    async def prometheus(request: Request) -> Response:
        return Response(generate_latest(metrics.registry), media_type=CONTENT_TYPE_LATEST)

    @contextlib.asynccontextmanager
    async def lifespan(app: Starlette) -> AsyncIterator[None]:
        if warm:
            threading.Thread(target=cell.warm, args=(progress,), name="photomodel-warm",
                             daemon=True).start()
        try:
            yield
        finally:
            cell.threads.close()

    routes = [
        Route("/", index),
        Route("/static/{name}", static),
        Route("/health", health),
        Route("/stats", stats),
        Route("/metrics", prometheus),
        WebSocketRoute("/track", track_endpoint(cell, metrics.registry, _finite)),
    ] + _library_routes(cell, work, limit) + _pair_routes(cell, work, limit) \
        + _source_routes(cell, work)
    app = Starlette(routes=routes, lifespan=lifespan,
                    exception_handlers=_exception_handlers(limit))
    app.state.cell = cell

    def observe(scope: Scope, status: int, seconds: float) -> None:
        endpoint, method = _endpoint(scope["path"]), scope.get("method", "")
        metrics.requests.labels(endpoint, method, str(status)).inc()
        metrics.latency.labels(endpoint).observe(seconds)
        if status >= 400:
            metrics.errors.labels(endpoint, str(status)).inc()
        if method in ("POST", "DELETE"):
            cell.latencies.add(f"{method} {endpoint}", status, seconds)

    return Guard(app, tokens=cell.tokens, audit=cell.audit, max_body_bytes=limit,
                 observe=observe)
