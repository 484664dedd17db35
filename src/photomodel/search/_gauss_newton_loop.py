"""Gauss-Newton's iterations in numba, for a fitness that gives its numba kernels.

A fitness whose values and normal equations have numba kernels
(:class:`~photomodel.fitness.KernelNormalEquations`, the ``soft`` fitness, through
``kernel_values`` and ``kernel_normal_equations``) is refined by
:func:`~photomodel.search.gauss_newton_refine`'s iterations in one compiled loop here, which
saves the Python around each iteration. Genes are pose vectors (6,) or pose vectors with the
model's strain (9,); maps are (4, 4) from model to camera 1. The arithmetic both loops share
(the strain prior's terms, the damped solve, the extrapolation, the step's slope, the
clipping, the map derivatives) is in the numba helpers below, which the Python loop calls
too: the two give the same result to the bit (``tests/search/test_kernel_loops.py``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from photomodel._jit import njit
from photomodel.fitness import kernel_normal_equations, kernel_values
from photomodel.geometry import pose_maps_kernel

CONVERGED, NO_ASCENT_CODE, OUT_OF_ITERATIONS = 0, 1, 2
"""The loop's stop codes."""


@njit(error_model="numpy")
def prior_values(V, prior):  # pragma: no cover - compiled
    """``v^T prior v`` (P,) of gene vectors ``V`` (P, G): the strain's prior."""
    out = np.zeros(V.shape[0])
    for p in range(V.shape[0]):
        s = 0.0
        for i in range(V.shape[1]):
            for j in range(V.shape[1]):
                s += V[p, i] * prior[i, j] * V[p, j]
        out[p] = s
    return out


@njit(error_model="numpy")
def add_prior(gradient, metric, prior, x, free):  # pragma: no cover - compiled
    """The prior's terms on the free genes: ``gradient -= 2 prior x``, ``metric += 2
    prior`` (in place)."""
    k = 0
    for i in range(x.shape[0]):
        if not free[i]:
            continue
        s = 0.0
        for j in range(x.shape[0]):
            s += prior[i, j] * x[j]
        gradient[k] -= 2.0 * s
        m = 0
        for j in range(x.shape[0]):
            if free[j]:
                metric[k, m] += 2.0 * prior[i, j]
                m += 1
        k += 1


@njit(error_model="numpy")
def damped_step(metric, damping, gradient):  # pragma: no cover - compiled
    """The step ``(metric + damping (diag metric + 1e-12))^-1 gradient`` (k,)."""
    k = gradient.shape[0]
    A = metric.copy()
    for i in range(k):
        A[i, i] += damping * (metric[i, i] + 1e-12)
    return np.linalg.solve(A, gradient)


@njit(error_model="numpy")
def slope_along(gradient, step, free):  # pragma: no cover - compiled
    """``gradient . step[free]``: the fitness's slope along ``step`` at its start."""
    s = 0.0
    k = 0
    for i in range(step.shape[0]):
        if free[i]:
            s += gradient[k] * step[i]
            k += 1
    return s


@njit(error_model="numpy")
def extrapolation(f, candidate_value, slope, most):  # pragma: no cover - compiled
    """The factor (1: none) by which to take an accepted step further: where the parabola
    through the fitness ``f`` at the start, its ``slope`` along the step there and its value
    ``candidate_value`` one step on peaks beyond 1.5 steps, that peak's distance in steps, at
    most ``most``."""
    curvature = 2.0 * (candidate_value - f - slope)
    if most <= 1.0 or not (slope > 0.0 and curvature < 0.0):
        return 1.0
    alpha = min(-slope / curvature, most)
    return alpha if alpha >= 1.5 else 1.0


@njit(error_model="numpy")
def map_derivatives(x: NDArray[np.float64], free: NDArray[np.bool_]
                     ) -> NDArray[np.float64]:  # pragma: no cover - compiled
    """Derivatives (k, 4, 4) of the map of gene vector ``x`` (6,: a pose vector, or 9,: and
    its strain; :func:`~photomodel.geometry.strained_matrices`) along each of its ``free``
    genes, in closed form. The rotation's entries are quadratic in the quaternion
    ``(e1, e2, e3, w)``, ``w = sqrt(1 - |e|^2)``, so along ``e_k`` they move by the
    quadratic form's two terms with ``dq = (unit k, -e_k / w)``; the strain moves the
    rotation's first two columns."""
    e1, e2, e3 = x[3], x[4], x[5]
    w = np.sqrt(max(1.0 - (e1 * e1 + e2 * e2 + e3 * e3), 1e-300))
    R = np.empty((3, 3))
    R[0, 0] = 1 - 2 * (e2 * e2 + e3 * e3)
    R[0, 1] = 2 * (e1 * e2 - e3 * w)
    R[0, 2] = 2 * (e1 * e3 + e2 * w)
    R[1, 0] = 2 * (e1 * e2 + e3 * w)
    R[1, 1] = 1 - 2 * (e1 * e1 + e3 * e3)
    R[1, 2] = 2 * (e2 * e3 - e1 * w)
    R[2, 0] = 2 * (e1 * e3 - e2 * w)
    R[2, 1] = 2 * (e2 * e3 + e1 * w)
    R[2, 2] = 1 - 2 * (e1 * e1 + e2 * e2)
    S = np.eye(2)      # the strain's stretch of the model plane
    if x.shape[0] > 6:
        S[0, 0] += x[6]
        S[1, 1] += x[7]
        S[0, 1] = S[1, 0] = x[8]
    out = np.zeros((int(np.sum(free)), 4, 4))
    D = np.empty((3, 3))
    k = 0
    for g in range(x.shape[0]):
        if not free[g]:
            continue
        if g < 3:
            out[k, g, 3] = 1.0
        elif g < 6:
            d1 = 1.0 if g == 3 else 0.0
            d2 = 1.0 if g == 4 else 0.0
            d3 = 1.0 if g == 5 else 0.0
            dw = -x[g] / w
            D[0, 0] = -4 * (e2 * d2 + e3 * d3)
            D[0, 1] = 2 * (d1 * e2 + e1 * d2 - d3 * w - e3 * dw)
            D[0, 2] = 2 * (d1 * e3 + e1 * d3 + d2 * w + e2 * dw)
            D[1, 0] = 2 * (d1 * e2 + e1 * d2 + d3 * w + e3 * dw)
            D[1, 1] = -4 * (e1 * d1 + e3 * d3)
            D[1, 2] = 2 * (d2 * e3 + e2 * d3 - d1 * w - e1 * dw)
            D[2, 0] = 2 * (d1 * e3 + e1 * d3 - d2 * w - e2 * dw)
            D[2, 1] = 2 * (d2 * e3 + e2 * d3 + d1 * w + e1 * dw)
            D[2, 2] = -4 * (e1 * d1 + e2 * d2)
            for i in range(3):
                for j in range(2):
                    out[k, i, j] = D[i, 0] * S[0, j] + D[i, 1] * S[1, j]
                out[k, i, 2] = D[i, 2]
        else:
            for i in range(3):
                if g == 6:
                    out[k, i, 0] = R[i, 0]
                elif g == 7:
                    out[k, i, 1] = R[i, 1]
                else:
                    out[k, i, 0] = R[i, 1]
                    out[k, i, 1] = R[i, 0]
        k += 1
    return out


@njit(inline="always", error_model="numpy")
def _gene_maps(V):  # pragma: no cover - compiled
    """Maps (P, 4, 4) of gene vectors (P, 6) or, with the strain, (P, 9)."""
    if V.shape[1] > 6:
        return pose_maps_kernel(np.ascontiguousarray(V[:, :6]), np.ascontiguousarray(V[:, 6:]))
    return pose_maps_kernel(np.ascontiguousarray(V), np.zeros((1, 3)))


@njit(error_model="numpy")
def clip_genes(v, lower, upper, max_strain):  # pragma: no cover - compiled
    """Gene vector ``v`` with its pose in the box (``lower``, ``upper``) (6,) and its strain
    within +-``max_strain``."""
    out = v.copy()
    for g in range(v.shape[0]):
        if g < 6:
            out[g] = min(max(v[g], lower[g]), upper[g])
        else:
            out[g] = min(max(v[g], -max_strain), max_strain)
    return out


@njit(inline="always", error_model="numpy")
def _values(lanes, args, V, prior):  # pragma: no cover - compiled
    """The fitness less the prior (P,) of gene vectors ``V``, the first one's offsets and
    the first one's fitness itself."""
    f, offsets = kernel_values(_gene_maps(V), lanes, args)
    return f - prior_values(V, prior), offsets[0].copy(), f[0]


@njit(inline="always", error_model="numpy")
def _fitness_gradient(lanes, args, x, f, h, free, prior):  # pragma: no cover
    """Forward differences of the fitness itself over the free genes at ``x`` (``f``)."""
    G = x.shape[0]
    V = np.empty((G, G))
    for i in range(G):
        for j in range(G):
            V[i, j] = x[j] + (h[i] if i == j else 0.0)
    fv = _values(lanes, args, V, prior)[0]
    out = np.empty(int(np.sum(free)))
    k = 0
    for g in range(G):
        if free[g]:
            out[k] = (fv[g] - f) / h[g]
            k += 1
    return out


@njit(error_model="numpy")
def gauss_newton_loop(lanes, vargs, nargs, x, free, h, lower,
                      upper, max_strain, prior, max_iterations, converged_steps, min_gain,
                      min_gain_steps, damping0, max_damping, rejected_damping, min_step,
                      most, f_start, offsets_start):  # pragma: no cover - compiled
    """``gauss_newton_refine``'s iterations from gene vector ``x`` (already clipped): the
    last accepted genes, their fitness less the prior, the evaluations, the fitness history,
    the stop code, and the fitness itself at the last accepted genes with the light offsets
    found there. ``f_start`` and ``offsets_start`` (2, 3): the fitness at ``x`` (itself, not
    less the prior) and its light offsets, when the caller evaluated it (NaN: evaluate it
    here)."""
    if np.isnan(f_start):
        f, offsets, raw = _values(lanes, vargs, x.reshape(1, -1), prior)
        f = f[0]
        evaluations = 1
    else:
        raw = f_start
        f = f_start - prior_values(x.reshape(1, -1), prior)[0]
        offsets = offsets_start.copy()
        evaluations = 0
    history = np.empty(max_iterations + 1)
    history[0] = f
    accepted = 0
    damping = damping0
    reason = OUT_OF_ITERATIONS
    differenced = False
    genes = x.shape[0]
    small_gains = 0
    step = np.zeros(genes)
    for _ in range(max_iterations):
        gradient, metric = kernel_normal_equations(_gene_maps(x.reshape(1, -1))[0],
                                  map_derivatives(x, free), offsets, True, nargs)
        evaluations += 1
        add_prior(gradient, metric, prior, x, free)
        if differenced:
            gradient = _fitness_gradient(lanes, vargs, x, f, h, free, prior)
            evaluations += genes
        candidate = x
        candidate_value = f
        candidate_raw = raw
        while True:
            solved = damped_step(metric, damping, gradient)
            step = np.zeros(genes)
            k = 0
            for g in range(genes):
                if free[g]:
                    step[g] = solved[k]
                    k += 1
            candidate = clip_genes(x + step, lower, upper, max_strain)
            value, moved, candidate_raw = _values(lanes, vargs, candidate.reshape(1, -1), prior)
            candidate_value = value[0]
            evaluations += 1
            if candidate_value > f:
                damping = max(damping / 3.0, 1e-4)
                offsets = moved
                alpha = extrapolation(f, candidate_value, slope_along(gradient, step, free), most)
                if alpha > 1.0:
                    further = clip_genes(x + alpha * step, lower, upper, max_strain)
                    value, moved, further_raw = _values(lanes, vargs, further.reshape(1, -1),
                                                        prior)
                    evaluations += 1
                    if value[0] > candidate_value:
                        candidate, candidate_value, step = further, value[0], further - x
                        candidate_raw = further_raw
                        offsets = moved
                break
            damping = max(4.0 * damping, rejected_damping)
            small = True
            for g in range(genes):
                if not abs(step[g]) <= min_step * h[g]:
                    small = False
            if damping > max_damping or small:
                if differenced:
                    break
                differenced, damping = True, damping0
                gradient = _fitness_gradient(lanes, vargs, x, f, h, free, prior)
                evaluations += genes
        if candidate_value <= f:
            reason = NO_ASCENT_CODE
            break
        small_gains = small_gains + 1 if candidate_value - f < min_gain else 0
        x, f, raw = candidate, candidate_value, candidate_raw
        accepted += 1
        history[accepted] = f
        done = True
        for g in range(genes):
            if not abs(step[g]) <= converged_steps * h[g]:
                done = False
        if done or small_gains >= min_gain_steps:
            reason = CONVERGED
            break
    return x, f, evaluations, history[:accepted + 1].copy(), reason, raw, offsets
