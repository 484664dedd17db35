"""What the benchmarks measure a pose against the truth with: its errors and the paper's
Table 1 form."""

from __future__ import annotations

from typing import Any

import numpy as np


def pose_errors(T_est: np.ndarray, T_true: np.ndarray) -> tuple[float, float, float, float]:
    """x, y, z (mm) and in-plane angle (deg) of ``T_est`` less ``T_true`` (camera 1)."""
    from photomodel.geometry import in_plane_angle_rad

    d = T_est[:3, 3] - T_true[:3, 3]
    dt = np.degrees(in_plane_angle_rad(T_est[:3, :3]) - in_plane_angle_rad(T_true[:3, :3]))
    return float(d[0]), float(d[1]), float(d[2]), float((dt + 180.0) % 360.0 - 180.0)


def table1(rows: list[tuple[float, float, float, float]]) -> dict[str, Any]:
    """The paper's Table 1 form: mean and sd of x, y, z (mm) and theta (deg)."""
    if not rows:
        return {"n": 0}
    a = np.asarray(rows)
    out: dict[str, Any] = {"n": len(rows)}
    for k, name in enumerate(("x_mm", "y_mm", "z_mm", "theta_deg")):
        out[name] = {"mean": float(a[:, k].mean()),
                     "sd": float(a[:, k].std(ddof=1)) if len(a) > 1 else 0.0}
    return out
