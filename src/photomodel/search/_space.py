"""The search space of pose vectors (x, y, z, eps1, eps2, eps3) of ``T_cam1_model``."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["GENE_NAMES", "SearchSpace"]

GENE_NAMES = ("x_mm", "y_mm", "z_mm", "eps1", "eps2", "eps3")


@dataclass(frozen=True)
class SearchSpace:
    """Box bounds (6,) on the pose vector; ``eps`` = quaternion vector part (w >= 0).

    A rotation by ``a`` about a unit axis has ``eps = sin(a / 2) * axis``, so an in-plane
    angle range of +-theta (about camera 1's z axis) is ``|eps3| <= sin(theta / 2)`` and a
    tilt range of +-tilt is ``|eps1|, |eps2| <= sin(tilt / 2)``.
    """

    lower: NDArray[np.float64]
    upper: NDArray[np.float64]

    def __post_init__(self) -> None:
        lo = np.asarray(self.lower, dtype=np.float64).reshape(6)
        hi = np.asarray(self.upper, dtype=np.float64).reshape(6)
        if not (np.isfinite(lo).all() and np.isfinite(hi).all()) or np.any(hi < lo):
            raise ValueError(f"search space: expected finite lower <= upper, got {lo}, {hi}")
        if lo[2] <= 0:
            raise ValueError(f"z_mm: the garment must be in front of camera 1, got {lo[2]}")
        if np.sum(np.maximum(np.abs(lo[3:]), np.abs(hi[3:])) ** 2) > 1:
            raise ValueError("eps bounds: the quaternion vector part must stay in the unit ball")
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)

    @classmethod
    def from_ranges(
        cls,
        x_mm: tuple[float, float] = (-255.0, 255.0),
        y_mm: tuple[float, float] = (-195.0, 195.0),
        z_mm: tuple[float, float] = (500.0, 900.0),
        theta_deg: float = 53.0,
        tilt_deg: float = 10.0,
    ) -> SearchSpace:
        """Bounds from position ranges (mm) and symmetric in-plane / tilt angle ranges (deg).

        The defaults are the paper's experiment (DESIGN.md): x +-255 mm, y +-195 mm,
        z 500-900 mm, in-plane angle +-53 deg, tilt +-10 deg.
        """
        if not (0 <= theta_deg <= 180 and 0 <= tilt_deg <= 90):
            raise ValueError(f"angles: expected 0 <= theta_deg <= 180 and 0 <= tilt_deg <= 90, "
                             f"got {theta_deg}, {tilt_deg}")
        e3 = np.sin(np.deg2rad(theta_deg) / 2)
        e12 = np.sin(np.deg2rad(tilt_deg) / 2)
        return cls(
            np.array([x_mm[0], y_mm[0], z_mm[0], -e12, -e12, -e3]),
            np.array([x_mm[1], y_mm[1], z_mm[1], e12, e12, e3]),
        )

    @property
    def span(self) -> NDArray[np.float64]:
        """upper - lower (6,)."""
        return self.upper - self.lower

    def clip(self, x: ArrayLike) -> NDArray[np.float64]:
        """Clip pose vectors (..., 6) into the box."""
        return np.clip(np.asarray(x, dtype=np.float64), self.lower, self.upper)

    def contains(self, x: ArrayLike) -> NDArray[np.bool_]:
        """Whether pose vectors (..., 6) lie inside the box."""
        x = np.asarray(x, dtype=np.float64)
        return np.all((x >= self.lower) & (x <= self.upper), axis=-1)
