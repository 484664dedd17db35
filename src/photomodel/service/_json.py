"""The service's JSON answers: NaN and infinities sent as null, and ``{"error": ...}``."""

from __future__ import annotations

import json
import math
from typing import Any

from starlette.responses import JSONResponse

__all__ = ["JSONAnswer", "error_response", "finite"]


def finite(obj: Any) -> Any:
    """``obj`` with every NaN or infinity as None (JSON has no NaN)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite(v) for v in obj]
    return obj


class JSONAnswer(JSONResponse):
    """A JSON answer; NaN and infinities (a score of nothing found) are sent as null."""

    def render(self, content: Any) -> bytes:
        return json.dumps(finite(content), allow_nan=False, separators=(",", ":")).encode()


def error_response(status: int, message: str, headers: dict[str, str] | None = None
                   ) -> JSONResponse:
    """``{"error": message}`` with ``status``."""
    return JSONAnswer({"error": message}, status_code=status, headers=headers)
