"""Checks the service's tests share."""

from __future__ import annotations

import httpx


def json_error(response: httpx.Response, status: int, *mentions: str) -> str:
    """The ``error`` of a JSON error answer with ``status`` (and nothing else in its body,
    no traceback), holding every text of ``mentions``."""
    assert response.status_code == status, response.text
    assert "Traceback" not in response.text
    body = response.json()
    assert set(body) == {"error"}, body
    for text in mentions:
        assert text in body["error"], (text, body)
    return body["error"]
