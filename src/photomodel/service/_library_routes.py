"""The library's and the results' routes: ``GET /models``, ``POST /models`` (a station photo
pair, a hand-camera pair in place, or the camera source's view), ``POST
/models/{name}/scale``, ``DELETE /models/{name}``, the previews, ``GET /results``, a result
and its overlay. Thin: the work is :class:`CellService`'s and the registering functions'."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import anyio
import anyio.to_thread
from starlette.requests import Request
from starlette.responses import Response
from starlette.routing import Route

from photomodel.errors import InputError
from photomodel.service._app import _JSON, _bool, _field, _file, _float, _form
from photomodel.service._cell import CellService, NotFound
from photomodel.service._register import register_from_camera, register_in_place, set_scale

__all__ = ["library_routes"]


def library_routes(cell: CellService, work: Callable[..., Any], limit: int) -> list[Route]:
    """The routes; ``work`` runs a call on the searches' threads, ``limit`` bounds a body."""
    # reading lists and overlays is bounded only by this (the searches by ``work``)
    limiter_unbounded = anyio.CapacityLimiter(64)

    rendered: list[Any] = [None, b""]     # the summaries last rendered and their JSON

    def models_json() -> bytes:
        summaries = cell.models()             # the same list until the library changes
        made_for, body = rendered
        if made_for is not summaries:
            body = _JSON(summaries).body
            rendered[:] = [summaries, body]
        return body

    async def list_models(request: Request) -> Response:
        # a catalogue's list takes a while to render once: not on the event loop
        body = await anyio.to_thread.run_sync(models_json, limiter=limiter_unbounded)
        return Response(body, media_type="application/json")

    async def add_model(request: Request) -> Response:
        form = await _form(request, limit)
        name = _field(form, "name", required=True)
        replace = _bool(form, "replace")
        source = _field(form, "source")
        if source is not None:                   # the garment where the cameras see it
            if source != "camera":
                raise InputError("source", f"expected 'camera', got {source!r}")
            summary = await work(register_from_camera, cell, name, replace=replace)
        elif form.get("right") is not None or form.get("left") is not None:
            views = [await _file(form, f) for f in ("right", "left")]
            empty = [await _file(form, f) if form.get(f) is not None else None
                     for f in ("empty_right", "empty_left")]
            summary = await work(register_in_place, cell, name, *views, *empty,
                                 replace=replace)
        else:
            photo, background = await _file(form, "photo"), await _file(form, "background")
            summary = await work(cell.register, name, photo, background,
                                 _float(form, "distance_mm"), replace=replace)
        return _JSON(summary, status_code=201)

    async def model_scale(request: Request) -> Response:
        form = await _form(request, limit)
        summary = await work(set_scale, cell, request.path_params["name"],
                             factor=_float(form, "factor"), result_id=_field(form, "result"))
        return _JSON(summary)

    async def delete_model(request: Request) -> Response:
        return _JSON(await work(cell.remove, request.path_params["name"]))

    async def preview(request: Request) -> Response:
        png = await work(cell.preview_png, request.path_params["name"])
        return Response(png, media_type="image/png")

    async def results(request: Request) -> Response:
        return _JSON(cell.results.recent(20))

    async def result(request: Request) -> Response:
        found = cell.results.get(request.path_params["id"])
        if found is None:
            raise NotFound("result", f"no result {request.path_params['id']!r} (only the "
                                     f"last {cell.results.size} are kept)")
        return _JSON(found.answer)

    async def overlay(request: Request) -> Response:
        rid = request.path_params["id"]
        png = await anyio.to_thread.run_sync(cell.results.overlay_png, rid,
                                             limiter=limiter_unbounded)
        if png is None:
            raise NotFound("result", f"no result {rid!r} (only the last "
                                     f"{cell.results.size} are kept)")
        return Response(png, media_type="image/png")

    return [Route("/models", list_models, methods=["GET"]),
            Route("/models", add_model, methods=["POST"]),
            Route("/models/{name}", delete_model, methods=["DELETE"]),
            Route("/models/{name}/scale", model_scale, methods=["POST"]),
            Route("/models/{name}/preview.png", preview),
            Route("/results", results),
            Route("/results/{id}", result),
            Route("/results/{id}/overlay.png", overlay)]
