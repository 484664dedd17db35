"""What the service remembers of its recent work: a bounded ring of results (with what their
overlay needs) and the latencies of the last requests."""

from __future__ import annotations

import threading
import time
import uuid
from collections import OrderedDict, deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["Latencies", "Result", "ResultRing"]


@dataclass
class Result:
    """One ``/locate`` or ``/identify`` answer.

    Attributes
    ----------
    id : str
        Its id in URLs (``/results/{id}/overlay.png``).
    kind : str
        ``"locate"`` or ``"identify"``.
    answer : dict
        The JSON object returned to the client.
    time_s : float
        Unix time of the answer.
    render : callable or None
        Draws the overlay PNG (bytes) on first request; dropped once drawn, so that the
        stereo pair it holds is released.
    """

    id: str
    kind: str
    answer: dict[str, Any]
    time_s: float
    render: Callable[[], bytes] | None = None
    _png: bytes | None = field(default=None, repr=False)

    def summary(self) -> dict[str, Any]:
        """What the operator page lists: id, kind, model, found, score, seconds, time."""
        a = self.answer
        return {"id": self.id, "kind": self.kind, "model": a.get("model"),
                "best_candidate": a.get("best_candidate"), "found": a.get("found"),
                "score": a.get("score"), "seconds": a.get("seconds"),
                "time_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(self.time_s)),
                "overlay": f"results/{self.id}/overlay.png"}


class ResultRing:
    """The last ``size`` results, oldest dropped first; safe to use from several threads."""

    def __init__(self, size: int = 20) -> None:
        if size < 1:
            raise ValueError(f"size: expected at least 1 result kept, got {size}")
        self.size = size
        self._items: OrderedDict[str, Result] = OrderedDict()
        self._lock = threading.Lock()

    def add(self, kind: str, answer: dict[str, Any], render: Callable[[], bytes] | None
            ) -> Result:
        """Keep a new result (its ``id`` is also written into ``answer``)."""
        result = Result(uuid.uuid4().hex[:16], kind, answer, time.time(), render)
        answer["id"] = result.id
        with self._lock:
            self._items[result.id] = result
            while len(self._items) > self.size:
                self._items.popitem(last=False)
        return result

    def get(self, result_id: str) -> Result | None:
        with self._lock:
            return self._items.get(result_id)

    def overlay_png(self, result_id: str) -> bytes | None:
        """The result's overlay (drawn on first request), None for an unknown id."""
        result = self.get(result_id)
        if result is None:
            return None
        with self._lock:
            render, png = result.render, result._png
        if png is None and render is not None:
            png = render()
            with self._lock:
                result._png, result.render = png, None
        return png

    def recent(self, count: int | None = None) -> list[dict[str, Any]]:
        """Summaries of the newest ``count`` results, newest first."""
        with self._lock:
            items = list(self._items.values())[::-1]
        return [r.summary() for r in items[:count]]

    def __len__(self) -> int:
        with self._lock:
            return len(self._items)


class Latencies:
    """Wall times of the last ``size`` requests, per endpoint."""

    def __init__(self, size: int = 100) -> None:
        self._items: deque[tuple[float, str, int, float]] = deque(maxlen=size)
        self._lock = threading.Lock()

    def add(self, endpoint: str, status: int, seconds: float) -> None:
        with self._lock:
            self._items.append((time.time(), endpoint, status, seconds))

    def summary(self) -> dict[str, Any]:
        """``{"count", "p50_ms", "p99_ms", "recent": [{"time_utc", "endpoint", "status",
        "ms"}]}`` over the window, newest first."""
        with self._lock:
            items = list(self._items)
        ms = np.array([s * 1000.0 for *_, s in items]) if items else np.zeros(0)
        return {
            "count": len(items),
            "p50_ms": float(np.percentile(ms, 50)) if len(ms) else None,
            "p99_ms": float(np.percentile(ms, 99)) if len(ms) else None,
            "recent": [{"time_utc": time.strftime("%H:%M:%S", time.gmtime(t)),
                        "endpoint": e, "status": st, "ms": round(s * 1000.0, 1)}
                       for t, e, st, s in reversed(items)],
        }
