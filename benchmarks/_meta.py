"""What every benchmark's JSON records: the commit, the machine and the library versions
(the same header as an experiment's summary, :func:`photomodel.experiments.run_metadata`)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from photomodel.experiments import run_metadata


def metadata(name: str, seed: int) -> dict[str, Any]:
    """The header of a benchmark's JSON."""
    return {"benchmark": name, "seed": seed, **run_metadata()}


def timed(fn: Callable[[], object], repeats: int) -> list[float]:
    """Wall-clock seconds of ``repeats`` calls of ``fn``."""
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out
