"""The protocols of a fitness whose numba kernels the searches' compiled loops call.

A fitness (``SoftFitness``) registers implementations of :func:`kernel_values` and
:func:`kernel_normal_equations` for the numba type of its ``kernel_args()`` /
``normal_args()`` with ``numba.extending.overload``; the searches' loops
(``photomodel.search``) call these names and never import a fitness.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

__all__ = ["KernelFitness", "KernelNormalEquations", "kernel_normal_equations", "kernel_values"]


@runtime_checkable
class KernelFitness(Protocol):
    """A fitness whose numba kernel the searches' numba loops call (``SoftFitness``)."""

    def __call__(self, poses: NDArray[np.float64]) -> NDArray[np.float64]: ...

    def kernel_args(self) -> tuple[Any, ...]:
        """The arguments of :func:`kernel_values` that give this fitness: a tuple whose numba
        type has an implementation registered for it."""
        ...


@runtime_checkable
class KernelNormalEquations(KernelFitness, Protocol):
    """A kernel fitness whose normal equations have a numba kernel too (``SoftFitness``)."""

    def normal_args(self) -> tuple[Any, ...]:
        """The arguments of :func:`kernel_normal_equations` that give this fitness's
        ``normal_equations``."""
        ...


def kernel_values(T: NDArray[np.float64], lanes: int, args: tuple[Any, ...]
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The fitness (P,) of maps ``T`` (P, 4, 4) of model points into camera 1, on ``lanes``
    threads, and the light offsets (P, 2, 3) it found for each pose (those of
    ``TransformFitness.last_offsets``), of the kernel fitness whose :meth:`KernelFitness.
    kernel_args` are ``args``.

    For numba code only: numba resolves it by the type of ``args`` to the implementation the
    fitness registers with ``numba.extending.overload`` (the ``soft`` fitness's in
    ``fitness/_soft_kernels.py``). The loops take no function arguments: numba's cache
    failed to save functions with one when two processes compiled them at once
    (``ReferenceError: underlying object has vanished``, numba/numba#9348)."""
    raise NotImplementedError("kernel_values runs inside numba code only")


def kernel_normal_equations(A: NDArray[np.float64], dA: NDArray[np.float64],
                            offsets: NDArray[np.float64], with_offsets: bool,
                            args: tuple[Any, ...]
                            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """What ``NormalEquationsFitness.normal_equations(A, dA, offsets, with_offsets)`` gives
    (gradient (G,), metric (G, G)) for the fitness whose :meth:`KernelNormalEquations.
    normal_args` are ``args``; resolved by numba as :func:`kernel_values`."""
    raise NotImplementedError("kernel_normal_equations runs inside numba code only")
