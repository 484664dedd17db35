"""The routes of the camera source: ``POST /trigger/locate``, ``POST /trigger/identify`` (a
fresh pair from the source, searched as ``/locate`` and ``/identify`` search an upload),
``POST /record?frames=N`` and the live view ``GET /camera/latest.jpg``. Thin: the work is
:class:`CellService`'s (``trigger_locate``, ``trigger_identify``, ``record``, ``feed``), as
for every face of the service."""

from __future__ import annotations

import re
from collections.abc import Awaitable, Callable
from typing import Any
from urllib.parse import parse_qsl

import anyio.to_thread
from starlette.datastructures import FormData
from starlette.requests import Request
from starlette.responses import Response
from starlette.routing import Route

from photomodel.errors import InputError
from photomodel.service._app import _JSON, _body, _field, _form, _seed
from photomodel.service._cell import CellService, Conflict, NotFound
from photomodel.service._record import MAX_RECORD_FRAMES

__all__ = ["trigger_routes"]

FIELDS_LIMIT_BYTES = 64 << 10
"""Largest body a trigger takes (its fields only: the images come from the source)."""

Work = Callable[..., Awaitable[Any]]


async def _fields(request: Request) -> FormData:
    """The request's fields: its query's and, when it has a body, its form's
    (``application/x-www-form-urlencoded`` or ``multipart/form-data``). A field given twice
    with two values is refused."""
    items: list[tuple[str, Any]] = list(request.query_params.multi_items())
    ctype = request.headers.get("content-type", "")
    if ctype.startswith("multipart/form-data"):
        items += list((await _form(request, FIELDS_LIMIT_BYTES)).multi_items())
    else:
        body = await _body(request, FIELDS_LIMIT_BYTES)
        if body.strip():
            if not ctype.startswith("application/x-www-form-urlencoded"):
                raise InputError("request", "expected the fields in the query, or as a form "
                                            "(application/x-www-form-urlencoded or "
                                            "multipart/form-data)")
            items += parse_qsl(body.decode("utf-8", "replace"), keep_blank_values=True)
    seen: dict[str, Any] = {}
    for key, value in items:
        if key in seen and seen[key] != value:
            raise InputError(key, "given twice with different values")
        seen[key] = value
    return FormData(list(seen.items()))


def _frames(fields: FormData) -> int:
    text = _field(fields, "frames", required=True)
    assert text is not None
    if not re.fullmatch(r"\d{1,9}", text.strip()) or \
            not 1 <= int(text) <= MAX_RECORD_FRAMES:
        raise InputError("frames", f"expected 1 to {MAX_RECORD_FRAMES} pairs, got {text!r}")
    return int(text)


def trigger_routes(cell: CellService, work: Work) -> list[Route]:
    """The routes, for :func:`~photomodel.service.create_app`; ``work`` runs a search in the
    app's bounded search threads."""

    async def trigger_locate(request: Request) -> Response:
        fields = await _fields(request)
        model = _field(fields, "model", required=True)
        return _JSON(await work(cell.trigger_locate, model, _seed(fields)))

    async def trigger_identify(request: Request) -> Response:
        fields = await _fields(request)
        return _JSON(await work(cell.trigger_identify, _seed(fields)))

    async def record(request: Request) -> Response:
        frames = _frames(await _fields(request))
        answer = await anyio.to_thread.run_sync(cell.record, frames)
        cell.audit.write("record", status=201,
                         detail=f"{answer['frames']} frames to {answer['path']}")
        return _JSON(answer, status_code=201)

    async def latest_jpeg(request: Request) -> Response:
        model = request.query_params.get("model") or None
        overlay = request.query_params.get("overlay", "1")
        if overlay not in ("0", "1"):
            raise InputError("overlay", f"expected 0 or 1, got {overlay!r}")
        if cell.source is None:
            raise Conflict("source", "this service has no camera source (start it with "
                                     "--source sim, replay:DIR or opencv:R,L)")
        if model is not None and model not in cell.identifier.entries:
            raise NotFound("model", f"no model named {model!r}")
        jpeg = await anyio.to_thread.run_sync(cell.feed.live_jpeg, model, overlay == "1")
        return Response(jpeg, media_type="image/jpeg", headers={"Cache-Control": "no-store"})

    return [Route("/trigger/locate", trigger_locate, methods=["POST"]),
            Route("/trigger/identify", trigger_identify, methods=["POST"]),
            Route("/record", record, methods=["POST"]),
            Route("/camera/latest.jpg", latest_jpeg)]
