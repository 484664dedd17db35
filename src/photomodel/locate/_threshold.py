"""The stored score threshold from which a located garment counts as on the table.

``locate`` (``soft`` fitness) reports ``found`` and ``identify`` accepts its best model when
the score reaches ``min_score``. The number is not chosen in the code:
:func:`calibrate_threshold` takes the scores of the true model in simulated scenes that show a
library garment (*positives*) and the best score of any model in scenes that show none
(*negatives*: empty tables, other garments and objects), and puts the threshold where it
separates them best under a cap on false acceptance. ``photomodel experiment --identify
--calibrate`` (:mod:`photomodel.experiments._identify`) runs it and writes ``threshold.json``
beside this module with the command, seed, counts and commit, which :func:`load_threshold`
reads.
"""

from __future__ import annotations

import functools
import json
import os
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from photomodel.errors import InputError

__all__ = ["THRESHOLD_FILE", "Threshold", "calibrate_threshold", "load_threshold",
           "save_threshold"]

THRESHOLD_FILE = "threshold.json"
"""Name of the package data file holding the calibrated threshold."""


@dataclass(frozen=True)
class Threshold:
    """A decision threshold and where it came from.

    Attributes
    ----------
    min_score : float
        Score in [0, 1] from which the best model counts as on the table.
    metadata : dict
        How it was calibrated: command, seed, conditions, counts, score statistics, commit.
    """

    min_score: float
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not 0.0 <= self.min_score <= 1.0:
            raise ValueError(f"min_score: expected a score in [0, 1], got {self.min_score}")


def calibrate_threshold(positives: ArrayLike, negatives: ArrayLike, *,
                        max_false_accept: float = 0.01) -> tuple[float, dict[str, Any]]:
    """The threshold that separates positives from negatives best.

    Among candidate thresholds (midpoints between consecutive distinct scores, and the ends),
    those whose false-acceptance rate on ``negatives`` is at most ``max_false_accept`` are
    kept; of these, the one with the fewest rejected positives wins, ties going to the middle
    of the widest gap (the largest distance to the nearest score of either kind).

    Parameters
    ----------
    positives : array (P,)
        Score of the true model in scenes that show it.
    negatives : array (N,)
        Best score of any model in scenes that show none.
    max_false_accept : float
        Largest allowed share of negatives at or above the threshold.

    Returns
    -------
    min_score : float
    stats : dict
        Counts, rates at the chosen threshold, and score quantiles of both sets.
    """
    pos = np.asarray(positives, dtype=np.float64).reshape(-1)
    neg = np.asarray(negatives, dtype=np.float64).reshape(-1)
    if len(pos) == 0 or len(neg) == 0:
        raise ValueError("calibrate_threshold: needs positive and negative scores")
    if not 0.0 <= max_false_accept < 1.0:
        raise ValueError(f"max_false_accept: expected [0, 1), got {max_false_accept}")
    values = np.unique(np.concatenate([pos, neg, [0.0, 1.0]]))
    cands = np.unique(np.clip(np.concatenate([(values[:-1] + values[1:]) / 2, [1.0]]), 0, 1))
    all_scores = np.concatenate([pos, neg])
    best: tuple[float, float, float] | None = None  # (rejected, -gap, t)
    for t in cands:
        fa = float(np.mean(neg >= t))
        if fa > max_false_accept:
            continue
        rejected = float(np.mean(pos < t))
        gap = float(np.min(np.abs(all_scores - t)))
        key = (rejected, -gap, float(t))
        if best is None or key < best:
            best = key
    assert best is not None  # t = 1.0 (or above every score) always passes
    t = best[2]

    def quantiles(x: np.ndarray) -> dict[str, float]:
        return {q: float(np.quantile(x, p)) for q, p in
                (("min", 0.0), ("p01", 0.01), ("p50", 0.5), ("p99", 0.99), ("max", 1.0))}

    stats = {
        "positives": int(len(pos)), "negatives": int(len(neg)),
        "false_accept_rate": float(np.mean(neg >= t)),
        "false_reject_rate": float(np.mean(pos < t)),
        "max_false_accept": max_false_accept,
        "positive_scores": quantiles(pos), "negative_scores": quantiles(neg),
    }
    return round(float(t), 4), stats


@functools.cache
def _data_path() -> Path:
    """The package data file's path, found once (``importlib.resources`` took 0.4 ms a call,
    and ``locate`` asks for it with every stereo pair)."""
    return Path(str(resources.files("photomodel.locate").joinpath(THRESHOLD_FILE)))


_READ: dict[Path, tuple[tuple[int, int, int], str]] = {}
"""Each threshold file's text when last read, by path, with its (inode, size, mtime_ns)."""


def load_threshold(path: str | os.PathLike[str] | None = None) -> Threshold:
    """Read a threshold file (default: the calibrated one shipped with the package).

    A file read before is read again only when its size, time or inode changed (a new
    calibration written by :func:`save_threshold`); ``locate`` asks for it with every pair.

    Raises
    ------
    InputError
        Missing or malformed file.
    """
    p = Path(path) if path is not None else _data_path()
    try:
        st = p.stat()
        key = (st.st_ino, st.st_size, st.st_mtime_ns)
        if p not in _READ or _READ[p][0] != key:
            _READ[p] = (key, p.read_text())
        data = json.loads(_READ[p][1])
        return Threshold(float(data["min_score"]), dict(data.get("metadata", {})))
    except FileNotFoundError:
        raise InputError(p, "threshold file not found") from None
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise InputError(p, f"not a threshold file ({exc})") from None


def save_threshold(threshold: Threshold, path: str | os.PathLike[str] | None = None) -> Path:
    """Write ``threshold`` atomically (default: the package data file)."""
    p = Path(path) if path is not None else _data_path()
    tmp = p.with_name(f".{p.name}.tmp")
    try:
        tmp.write_text(json.dumps({"min_score": threshold.min_score,
                                   "metadata": threshold.metadata}, indent=1) + "\n")
        os.replace(tmp, p)
    finally:
        tmp.unlink(missing_ok=True)
    return p
