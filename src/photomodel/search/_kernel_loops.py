"""The local searches' loops in numba, for a fitness whose numba kernel they can call.

A fitness whose numba kernel the loop can call (:class:`KernelFitness`, the ``soft`` fitness,
through :func:`kernel_values`) is searched by :class:`~photomodel.search.LocalRefine`'s
strategy in one compiled loop, without the Python of ask/tell around each iteration: the
same draws from the caller's generator in the same order, the same arithmetic, the same
result to the bit (``tests/search/test_kernel_loops.py``). Poses are pose vectors (6,) in
camera 1's frame, or flat pose vectors laid on a plane (:class:`OnPlane`).
"""

from __future__ import annotations

from collections.abc import Callable

import numba
import numpy as np
from numpy.typing import NDArray

from photomodel._jit import njit
from photomodel.fitness import KernelFitness, kernel_values
from photomodel.geometry import facing_kernel, facing_pose_vectors, pose_maps_kernel
from photomodel.search._base import SearchResult, conforms
from photomodel.search._refine import RefineConfig
from photomodel.search._space import SearchSpace

__all__ = ["OnPlane", "kernel_fitness", "plane_poses", "refine_kernel"]


def plane_poses(flat: NDArray[np.float64], space: SearchSpace,
                q_facing: NDArray[np.float64]) -> NDArray[np.float64]:
    """Pose vectors (N, 6) of *flat* pose vectors ``(x, y, z, -, -, sin(theta / 2))`` (N, 6)
    laid on the plane of ``quat_wxyz`` ``q_facing``
    (:func:`~photomodel.geometry.facing_pose_vectors`), clipped into ``space``."""
    return space.clip(facing_pose_vectors(flat, q_facing))


class OnPlane:
    """``objective`` of flat pose vectors laid on the plane of ``quat_wxyz`` ``q_facing``
    (``R_cam1_facing``'s) and clipped into ``space`` (:func:`plane_poses`)."""

    def __init__(self, objective: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                 space: SearchSpace, q_facing: NDArray[np.float64]) -> None:
        self.objective = objective
        self.space = space
        self.q_facing = np.asarray(q_facing, dtype=np.float64).reshape(4)

    def __call__(self, flat: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.objective(plane_poses(flat, self.space, self.q_facing))


def kernel_fitness(objective: object) -> KernelFitness | None:
    """The :class:`KernelFitness` that ``objective`` evaluates (itself, or the one an
    :class:`OnPlane` lays on its plane), None where it has no kernel."""
    fitness = objective.objective if isinstance(objective, OnPlane) else objective
    return fitness if conforms(fitness, KernelFitness) else None


def refine_kernel(objective: KernelFitness | OnPlane, space: SearchSpace,
                  x0: NDArray[np.float64], config: RefineConfig,
                  rng: np.random.Generator) -> SearchResult:
    """:class:`~photomodel.search.LocalRefine` of ``objective`` from ``x0`` in ``space``,
    run to its stop in one numba loop: the result of ``run_search(LocalRefine(space, x0,
    objective(x0), config, rng), objective)``, with ``rng`` left where that leaves it.

    ``objective`` is a :class:`KernelFitness`, or an :class:`OnPlane` of one (``space``
    then holds flat pose vectors).
    """
    plane = objective if isinstance(objective, OnPlane) else None
    fitness = kernel_fitness(objective)
    if fitness is None:
        raise TypeError("refine_kernel: expected a KernelFitness or an OnPlane of one")
    args = fitness.kernel_args()
    c = config
    state = rng.bit_generator.state
    normals = rng.standard_normal((c.max_iterations, c.population, 6))
    q = plane.q_facing if plane is not None else np.array([1.0, 0.0, 0.0, 0.0])
    box = plane.space if plane is not None else space
    x, f, iterations, converged, best, mean = _refine_loop(
        numba.get_num_threads(), args, np.asarray(x0, dtype=np.float64).reshape(6),
        c.steps, normals, space.lower, space.upper, c.grow, c.shrink, c.min_step_fraction,
        c.max_iterations, plane is not None, q, box.lower, box.upper)
    rng.bit_generator.state = state     # the draws used, as LocalRefine draws them
    rng.standard_normal((iterations, c.population, 6))
    reason = ("refined (steps converged)" if converged
              else f"refine max_iterations ({c.max_iterations})")
    return SearchResult(x, float(f), iterations * c.population, iterations, reason, best, mean)


@njit(error_model="numpy")
def _plane_maps(X, on_plane, q, lower, upper):  # pragma: no cover - compiled
    """The maps (P, 4, 4) of pose vectors ``X`` (P, 6), laid on the plane of quaternion ``q``
    and clipped into (``lower``, ``upper``) first when ``on_plane``."""
    if on_plane:
        X = np.minimum(np.maximum(facing_kernel(X, q[0], q[1], q[2], q[3]), lower), upper)
    return pose_maps_kernel(X, np.zeros((1, 3)))


@njit(error_model="numpy")
def _refine_loop(lanes, args, x0, step0, normals, lower, upper, grow, shrink, min_fraction,
                 max_iterations, on_plane, q, plane_lower,
                 plane_upper):  # pragma: no cover - compiled
    """:class:`LocalRefine`'s iterations with the draws ``normals`` (max_iterations, P, 6):
    the best pose and fitness, the iterations, whether the steps converged, and the best and
    mean fitness of each iteration."""
    population = normals.shape[1]
    f0 = kernel_values(_plane_maps(x0.reshape(1, 6), on_plane, q, plane_lower, plane_upper),
                lanes, args)[0][0]
    best_x = np.minimum(np.maximum(x0, lower), upper)
    best_f = f0
    step = step0.copy()
    best = np.empty(max_iterations)
    mean = np.empty(max_iterations)
    it = 0
    converged = False
    X = np.empty((population, 6))
    while True:
        converged = True
        for g in range(6):
            if not step[g] < step0[g] * min_fraction:
                converged = False
        if converged or it >= max_iterations:
            break
        centre = best_x.copy()      # ray coordinates (x/z, y/z, z, eps)
        centre[0] = best_x[0] / best_x[2]
        centre[1] = best_x[1] / best_x[2]
        for p in range(population):
            for g in range(6):
                X[p, g] = centre[g] + normals[it, p, g] * step[g]
            X[p, 0] = X[p, 0] * X[p, 2]
            X[p, 1] = X[p, 1] * X[p, 2]
            for g in range(6):
                X[p, g] = min(max(X[p, g], lower[g]), upper[g])
        maps = _plane_maps(X, on_plane, q, plane_lower, plane_upper)
        f = kernel_values(maps, lanes, args)[0]
        i = 0
        total = 0.0
        for p in range(population):
            total += f[p]
            if f[p] > f[i]:
                i = p
        improved = f[i] > best_f
        if improved:
            best_f = f[i]
            best_x = X[i].copy()
        best[it] = best_f
        mean[it] = total / population
        for g in range(6):
            step[g] = min(step[g] * (grow if improved else shrink), step0[g] * 4)
        it += 1
    return best_x, best_f, it, converged, best[:it].copy(), mean[:it].copy()
