"""The ask/tell optimiser interface shared by every search method (after pycma)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

__all__ = ["Optimizer", "SearchResult", "conforms", "run_search"]


@dataclass(frozen=True)
class SearchResult:
    """The best pose found and how the search went.

    Attributes
    ----------
    x : ndarray (6,)
        Best pose vector (x, y, z mm, eps1, eps2, eps3).
    fitness : float
        Its fitness.
    evaluations : int
        Fitness evaluations used.
    iterations : int
        Generations (GA) or batches (full search).
    stop_reason : str
        Why the search stopped.
    best_history, mean_history : ndarray (iterations,)
        Best-so-far and population-mean fitness per iteration.
    strain : ndarray (3,) or None
        In-plane strain ``(e_xx, e_yy, e_xy)`` of the model found with the pose
        (:func:`~photomodel.geometry.strained_matrices`), for searches that fit one.
    at_x : (float, ndarray (2, 3)) or None
        The fitness's own evaluation at ``x`` (with ``strain``), as it returned it, and the
        light offsets it found there, where the search kept them (Gauss-Newton on the
        ``soft`` fitness): a caller that would evaluate ``x`` again can take them.
    """

    x: NDArray[np.float64]
    fitness: float
    evaluations: int
    iterations: int
    stop_reason: str
    best_history: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    mean_history: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    strain: NDArray[np.float64] | None = None
    at_x: tuple[float, NDArray[np.float64]] | None = None


class Optimizer(Protocol):
    """Maximises a fitness over a :class:`~photomodel.search.SearchSpace`.

    ``ask()`` returns candidate pose vectors (P, 6); ``tell(x, f)`` takes them back with their
    fitness (P,); ``stop()`` is None while the search goes on, else the reason it stopped;
    ``result`` is the best so far.
    """

    def ask(self) -> NDArray[np.float64]: ...

    def tell(self, x: NDArray[np.float64], fitness: NDArray[np.float64]) -> None: ...

    def stop(self) -> str | None: ...

    @property
    def result(self) -> SearchResult: ...


def run_search(
    optimizer: Optimizer,
    fitness: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    callback: Callable[[Optimizer], None] | None = None,
) -> SearchResult:
    """Drive ``optimizer`` with ``fitness`` until it stops; ``callback`` after each tell."""
    while optimizer.stop() is None:
        x = optimizer.ask()
        optimizer.tell(x, np.asarray(fitness(x), dtype=np.float64))
        if callback is not None:
            callback(optimizer)
    return optimizer.result


def generation_stop(generation: int, since_improvement: int, max_generations: int,
                    patience: int) -> str | None:
    """The generational optimisers' stop rule: a generation limit, or ``patience``
    generations without improvement (checked after restarts are spent)."""
    if generation >= max_generations:
        return f"max_generations ({max_generations})"
    if since_improvement >= patience:
        return f"no improvement for {patience} generations"
    return None


class _Tracker:
    """Best-so-far bookkeeping shared by the optimisers."""

    def __init__(self) -> None:
        self.best_x: NDArray[np.float64] | None = None
        self.best_f = -np.inf
        self.evaluations = 0
        self.best_history: list[float] = []
        self.mean_history: list[float] = []

    def update(self, x: NDArray[np.float64], f: NDArray[np.float64]) -> bool:
        """Record a batch; True when it improved the best."""
        x = np.asarray(x, dtype=np.float64).reshape(-1, 6)
        f = np.asarray(f, dtype=np.float64).reshape(-1)
        if len(x) != len(f):
            raise ValueError(f"tell: {len(x)} solutions but {len(f)} fitness values")
        self.evaluations += len(f)
        i = int(np.argmax(f))
        improved = bool(f[i] > self.best_f)
        if improved:
            self.best_f = float(f[i])
            self.best_x = x[i].copy()
        self.best_history.append(self.best_f)
        self.mean_history.append(float(f.sum() / len(f)))     # np.mean's sum, without its wrapper
        return improved

    def result(self, stop_reason: str) -> SearchResult:
        x = np.full(6, np.nan) if self.best_x is None else self.best_x
        return SearchResult(x, self.best_f, self.evaluations, len(self.best_history),
                            stop_reason, np.array(self.best_history), np.array(self.mean_history))


def conforms(obj: object, protocol: Any) -> bool:
    """``isinstance(obj, protocol)`` for a ``runtime_checkable`` protocol, decided once per
    type of ``obj``: such a check looks up every member of the protocol (about 60 us), and a
    search asks it a few dozen times a stereo pair. The project's fitnesses give their
    methods on the class, so the type decides."""
    key = (type(obj), protocol)
    if key not in _CONFORMS:
        _CONFORMS[key] = isinstance(obj, protocol)
    return _CONFORMS[key]


_CONFORMS: dict[tuple[type, Any], bool] = {}

