"""``POST /locate`` and ``POST /identify``: the two views as image files (multipart, decoded
as before), as raw pixels or ``.npy`` parts of the multipart form, or as one
``application/octet-stream`` body of raw pixels with the fields in the query (no multipart
parsing). Thin: the pixels are read by :mod:`._pixels`, the search is
:class:`CellService`'s."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray
from starlette.datastructures import FormData, UploadFile
from starlette.requests import Request
from starlette.responses import Response
from starlette.routing import Route

from photomodel.errors import InputError
from photomodel.image import decode_color_image
from photomodel.service._app import _JSON, _body, _field, _file, _form, _seed, _TooLarge
from photomodel.service._cell import CellService, NotFound
from photomodel.service._guard import drain
from photomodel.service._pixels import npy_view, raw_layout, raw_pair, raw_view

__all__ = ["pair_routes"]

Work = Callable[..., Awaitable[Any]]
RAW = "application/octet-stream"
NPY = "application/x-npy"
_Pair = tuple[NDArray[np.uint8], NDArray[np.uint8]]


def _kind(upload: UploadFile, sized: bool) -> str:
    """``raw``, ``npy`` or ``image`` (a container OpenCV decodes) for an uploaded part.

    An ``application/octet-stream`` part is raw pixels only when the form gives their size
    (``sized``: a ``width`` or ``height`` field): many clients send every file, PNG
    included, as ``application/octet-stream``, and those stay image files as before.
    """
    ctype = (upload.content_type or "").split(";")[0].strip().lower()
    if ctype == NPY or (upload.filename or "").lower().endswith(".npy"):
        return "npy"
    return "raw" if ctype == RAW and sized else "image"


async def _parts(form: FormData) -> tuple[bytes, bytes, Callable[[], _Pair] | None]:
    """The two parts' bytes, and a function decoding them when either is raw or ``.npy``
    (None when both are image files: :meth:`CellService.decode_pair` as before)."""
    right, left = await _file(form, "right"), await _file(form, "left")
    sized = _field(form, "width") is not None or _field(form, "height") is not None
    kinds = {name: _kind(form[name], sized) for name in ("right", "left")}
    if set(kinds.values()) == {"image"}:
        return right, left, None
    fmt = _field(form, "pixel_format")
    layout = (raw_layout(_field(form, "width"), _field(form, "height"), fmt)
              if "raw" in kinds.values() else None)

    def view(data: bytes, name: str) -> NDArray[np.uint8]:
        if kinds[name] == "raw":
            assert layout is not None
            return raw_view(data, name, layout)
        if kinds[name] == "npy":
            return npy_view(data, name, fmt)
        return decode_color_image(data, name)

    return right, left, lambda: (view(right, "right"), view(left, "left"))


async def _raw_body(request: Request, limit: int) -> tuple[FormData, Callable[[], _Pair]]:
    """The query's fields and the body's two views (right then left)."""
    size = request.headers.get("content-length")
    if size is not None and size.isdigit() and int(size) > limit:
        await drain(request.receive, 2 * limit)
        raise _TooLarge()
    query = FormData(list(request.query_params.multi_items()))
    body = await _body(request, limit)
    layout = raw_layout(_field(query, "width"), _field(query, "height"),
                        _field(query, "pixel_format"))
    return query, lambda: raw_pair(body, layout)


def _is_raw(request: Request) -> bool:
    return request.headers.get("content-type", "").split(";")[0].strip().lower() == RAW


def _all(fields: FormData) -> bool:
    """The ``all`` field: every garment (``true``/``1``) or the best one (absent, ``false``,
    ``0``)."""
    text = _field(fields, "all")
    if text is None or text.strip().lower() in ("false", "0"):
        return False
    if text.strip().lower() in ("true", "1"):
        return True
    raise InputError("all", f"expected true or false, got {text!r}")


def pair_routes(cell: CellService, work: Work, limit: int) -> list[Route]:
    """The routes, for :func:`~photomodel.service.create_app`; ``work`` runs a search in the
    app's bounded search threads, ``limit`` bounds a body (bytes, 413 beyond)."""

    def locate_views(model: str, views: Callable[[], _Pair], seed: int | None
                     ) -> dict[str, Any]:
        if model not in cell.identifier.entries:
            raise NotFound("model", f"no model named {model!r}")
        return cell.locate_pair(model, *views(), seed)

    def identify_views(views: Callable[[], _Pair], seed: int | None, every: bool
                       ) -> dict[str, Any]:
        cell.ready()
        return cell.identify_pair(*views(), seed, every=every)

    async def locate(request: Request) -> Response:
        if _is_raw(request):
            query, views = await _raw_body(request, limit)
            model = _field(query, "model", required=True)
            assert model is not None
            return _JSON(await work(locate_views, model, views, _seed(query)))
        form = await _form(request, limit)
        model = _field(form, "model", required=True)
        assert model is not None
        right, left, decode = await _parts(form)
        if decode is None:
            return _JSON(await work(cell.locate, model, right, left, _seed(form)))
        return _JSON(await work(locate_views, model, decode, _seed(form)))

    async def identify(request: Request) -> Response:
        if _is_raw(request):
            query, views = await _raw_body(request, limit)
            return _JSON(await work(identify_views, views, _seed(query), _all(query)))
        form = await _form(request, limit)
        right, left, decode = await _parts(form)
        if decode is None:
            return _JSON(await work(cell.identify, right, left, _seed(form),
                                    every=_all(form)))
        return _JSON(await work(identify_views, decode, _seed(form), _all(form)))

    return [Route("/locate", locate, methods=["POST"]),
            Route("/identify", identify, methods=["POST"])]

