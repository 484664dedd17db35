"""Normalised coordinates of the search box, shared by the real-valued optimisers.

Gene ``g`` of a pose vector maps to ``u = (x - lower[g]) / span[g]`` in [0, 1], so that one
step size fits position (mm) and orientation (eps) alike. A gene with zero span (fixed by
the box) maps every ``u`` to ``lower[g]``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel.search._space import SearchSpace

__all__ = ["DEFAULT_START_FRACTION", "UnitBox", "reflect"]

DEFAULT_START_FRACTION = 0.1
"""Spread of a population started around ``x0`` when no ``sigma0`` is given, as a
fraction of each gene's range."""


def reflect(u: NDArray[np.float64]) -> NDArray[np.float64]:
    """Fold unit coordinates back into [0, 1] by mirroring at the faces (any overshoot)."""
    u = np.mod(u, 2.0)
    return np.where(u > 1.0, 2.0 - u, u)


class UnitBox:
    """Maps pose vectors (..., 6) of ``space`` to and from the unit cube [0, 1]^6."""

    def __init__(self, space: SearchSpace) -> None:
        self.space = space
        self._scale = np.where(space.span > 0, space.span, 1.0)

    def to_unit(self, x: ArrayLike) -> NDArray[np.float64]:
        """Unit coordinates of pose vectors (..., 6), clipped to [0, 1]."""
        u = (np.asarray(x, dtype=np.float64) - self.space.lower) / self._scale
        return np.clip(u, 0.0, 1.0)

    def from_unit(self, u: ArrayLike) -> NDArray[np.float64]:
        """Pose vectors (..., 6) of unit coordinates, clipped into the box."""
        return self.space.clip(self.space.lower + self.space.span * np.asarray(u, np.float64))

    def start(self, x0: ArrayLike | None, sigma0: ArrayLike | None
              ) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
        """Validate a start pose and its spread; return both in unit coordinates.

        Parameters
        ----------
        x0 : array_like (6,) or None
            Start pose (x, y, z mm, eps1, eps2, eps3); clipped into the box.
        sigma0 : array_like (6,) or None
            Spread around ``x0`` per gene in pose units (mm, eps); default
            ``DEFAULT_START_FRACTION`` of each gene's range. Only used with ``x0``.

        Returns
        -------
        (u0, s0) : two ndarrays (6,), or None when ``x0`` is None.
        """
        if x0 is None:
            if sigma0 is not None:
                raise ValueError("sigma0: given without x0 (it is the spread around x0)")
            return None
        x = np.asarray(x0, dtype=np.float64)
        if x.shape != (6,) or not np.isfinite(x).all():
            raise ValueError(f"x0: expected a finite pose vector (6,), got shape {x.shape}: {x}")
        if sigma0 is None:
            s0 = np.full(6, DEFAULT_START_FRACTION)
        else:
            s = np.asarray(sigma0, dtype=np.float64)
            if s.shape != (6,) or not (np.isfinite(s).all() and np.all(s > 0)):
                raise ValueError(f"sigma0: expected six positive step sizes (mm, eps), "
                                 f"got shape {s.shape}: {s}")
            s0 = s / self._scale
        return self.to_unit(x), s0

    def initial_population(self, rng: np.random.Generator, size: int,
                           x0: ArrayLike | None, sigma0: ArrayLike | None
                           ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """A first population (size, 6) in unit coordinates and the start spread.

        Uniform over the box without ``x0``; else ``x0`` itself followed by normal draws of
        spread ``sigma0`` around it (clipped into the box). The spread (6,) in unit
        coordinates is returned too (None without ``x0``), see :meth:`start`.
        """
        start = self.start(x0, sigma0)
        if start is None:
            return rng.random((size, 6)), None
        u0, s0 = start
        draws = u0 + s0 * rng.standard_normal((size - 1, 6))
        return np.vstack([u0, np.clip(draws, 0.0, 1.0)]), s0
