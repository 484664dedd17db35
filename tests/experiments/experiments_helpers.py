"""Test helpers for the experiment tests: records built by hand with known errors."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel.experiments._records import COLUMNS, FLOAT_COLUMNS


def make_records(err_x: ArrayLike, err_y: ArrayLike, err_z: ArrayLike, err_theta: ArrayLike,
                 garment: str | Sequence[str] = "No.3", found: ArrayLike = 1,
                 seconds: ArrayLike = 1.0, condition: str = "paper") -> dict[str, NDArray[Any]]:
    """A records dict with every column of ``records.csv``, dtypes as ``read_records`` gives.

    Errors are given; ``err_xy_mm`` is ``hypot(err_x, err_y)``; true poses are fixed and the
    estimates are truth plus error (theta not wrapped: the recorded error is what counts).
    """
    ex = np.asarray(err_x, dtype=np.float64)
    n = ex.size
    cols: dict[str, NDArray[Any]] = {c: np.zeros(n) for c in FLOAT_COLUMNS}
    cols["err_x_mm"] = ex
    cols["err_y_mm"] = np.broadcast_to(np.asarray(err_y, dtype=np.float64), (n,)).copy()
    cols["err_z_mm"] = np.broadcast_to(np.asarray(err_z, dtype=np.float64), (n,)).copy()
    cols["err_theta_deg"] = np.broadcast_to(np.asarray(err_theta, dtype=np.float64),
                                            (n,)).copy()
    cols["err_xy_mm"] = np.hypot(cols["err_x_mm"], cols["err_y_mm"])
    cols["seconds"] = np.broadcast_to(np.asarray(seconds, dtype=np.float64), (n,)).copy()
    cols["true_z_mm"] = np.full(n, 685.0)
    for a in ("x_mm", "y_mm", "z_mm", "theta_deg"):
        cols[f"est_{a}"] = cols[f"true_{a}"] + cols[f"err_{a}"]
    names = [garment] * n if isinstance(garment, str) else list(garment)
    cols["garment"] = np.array(names, dtype=str)
    cols["condition"] = np.array([condition] * n, dtype=str)
    cols["trial_id"] = np.array([f"{condition}_{g}_{i:04d}" for i, g in enumerate(names)],
                                dtype=str)
    cols["stop_reason"] = np.array(["generations"] * n, dtype=str)
    cols["index"] = np.arange(n, dtype=np.int64)
    cols["found"] = np.broadcast_to(np.asarray(found, dtype=np.int64), (n,)).copy()
    cols["evaluations"] = np.full(n, 6000, dtype=np.int64)
    cols["generations"] = np.full(n, 100, dtype=np.int64)
    assert set(cols) == set(COLUMNS)
    return cols


def concat_records(*parts: dict[str, NDArray[Any]]) -> dict[str, NDArray[Any]]:
    """Rows of several records dicts, in order."""
    return {c: np.concatenate([p[c] for p in parts]) for c in COLUMNS}
