"""What every fitness function offers the search: whole populations in one call."""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import NDArray


class Fitness(Protocol):
    """A fitness over pose vectors (x, y, z, eps1, eps2, eps3) of ``T_cam1_model``."""

    name: str

    def __call__(self, poses: NDArray[np.float64]) -> NDArray[np.float64]:
        """Fitness (P,) of pose vectors (P, 6); larger is better."""
        ...

    def score(self, fitness: float) -> float:
        """Map a fitness value to [0, 1] (1 = every model point agrees with the images)."""
        ...
