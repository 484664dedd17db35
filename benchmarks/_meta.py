"""What every benchmark's JSON records: the commit, the machine and the library versions."""

from __future__ import annotations

import platform
import subprocess
import time
from collections.abc import Callable
from importlib.metadata import version
from typing import Any

PACKAGES = ("numpy", "numba", "opencv-python-headless", "scipy", "scikit-image", "photomodel")


def commit() -> str:
    """The checked-out commit (``unknown`` outside a git checkout)."""
    try:
        return subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def metadata(name: str, seed: int) -> dict[str, Any]:
    """The header of a benchmark's JSON."""
    return {
        "benchmark": name,
        "commit": commit(),
        "seed": seed,
        "machine": {"platform": platform.platform(), "processor": platform.processor(),
                    "python": platform.python_version()},
        "versions": {p: version(p) for p in PACKAGES},
    }


def timed(fn: Callable[[], object], repeats: int) -> list[float]:
    """Wall-clock seconds of ``repeats`` calls of ``fn``."""
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out
