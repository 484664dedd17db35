"""The stored score threshold from which a located garment counts as on the table.

``locate`` (``soft`` fitness) reports ``found`` and ``identify`` accepts its best model when
the score reaches ``min_score``. The number is not chosen in the code:
:func:`calibrate_threshold` takes the scores of the true model in simulated scenes that show a
library garment (*positives*) and the best score of any model in scenes that show none
(*negatives*: empty tables, other garments and objects), and puts the threshold where it
separates them best under a cap on false acceptance. ``photomodel experiment --identify
--calibrate`` (:mod:`photomodel.experiments._identify`) runs it and writes a threshold file
(the command, seed, counts and commit with it) to the user's file, :func:`user_threshold_path`,
or where ``--threshold-file`` says; the package's own file is only read.

Which file applies (:func:`threshold_path`): one given explicitly; else ``threshold.json`` in
the model library's folder (for ``identify``); else the user's file when it exists; else the
default shipped with the package.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from photomodel._files import write_atomic
from photomodel.errors import InputError

__all__ = ["THRESHOLD_FILE", "Threshold", "calibrate_threshold", "load_threshold",
           "save_threshold", "threshold_path", "user_threshold_path"]

THRESHOLD_FILE = "threshold.json"
"""Name of a threshold file: the package's default, the user's, a model library's."""


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


def _package_path() -> Path:
    """The default threshold file shipped with the package (read only)."""
    return Path(str(resources.files("photomodel.locate").joinpath(THRESHOLD_FILE)))


def user_threshold_path() -> Path:
    """The user's threshold file: ``$PHOTOMODEL_THRESHOLD`` when set, else
    ``$XDG_CONFIG_HOME/photomodel/threshold.json`` (``~/.config/photomodel/threshold.json``)."""
    explicit = os.environ.get("PHOTOMODEL_THRESHOLD")
    if explicit:
        return Path(explicit)
    config = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(config) / "photomodel" / THRESHOLD_FILE


def threshold_path(path: str | os.PathLike[str] | None = None,
                   library: str | os.PathLike[str] | None = None) -> Path:
    """The threshold file that applies (see the module docstring): ``path`` when given, else
    ``library``'s ``threshold.json`` when it exists, else the user's file when it exists,
    else the package's default."""
    if path is not None:
        return Path(path)
    if library is not None and (Path(library) / THRESHOLD_FILE).is_file():
        return Path(library) / THRESHOLD_FILE
    user = user_threshold_path()
    return user if user.is_file() else _package_path()


def load_threshold(path: str | os.PathLike[str] | None = None, *,
                   library: str | os.PathLike[str] | None = None) -> Threshold:
    """Read the threshold file that applies (:func:`threshold_path`).

    Raises
    ------
    InputError
        Missing or malformed file.
    """
    p = threshold_path(path, library)
    try:
        data = json.loads(p.read_text())
        if not isinstance(data, dict):
            raise ValueError("expected a JSON object")
        return Threshold(float(data["min_score"]), dict(data.get("metadata", {})))
    except FileNotFoundError:
        raise InputError(p, "threshold file not found") from None
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise InputError(p, f"not a threshold file ({exc})") from None


def save_threshold(threshold: Threshold, path: str | os.PathLike[str] | None = None) -> Path:
    """Write ``threshold`` atomically to ``path`` (default: :func:`user_threshold_path`;
    never the package's own file)."""
    p = Path(path) if path is not None else user_threshold_path()
    if p.resolve() == _package_path().resolve():
        raise InputError(p, "is the package's default threshold; write to a user file")
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(p, f"cannot create its folder ({exc.strerror})") from None
    write_atomic(p, (json.dumps({"min_score": threshold.min_score,
                                 "metadata": threshold.metadata}, indent=1) + "\n").encode())
    return p
