"""Numba kernel of the ``soft`` residuals' normal equations, with their analytic Jacobian.

A residual is a bilinear sample of a smoothed feature image less the colour the model expects
there (:func:`~photomodel.fitness._soft_kernels._camera_residuals`). Its derivative with
respect to a gene that moves the sample's camera point ``X`` by ``dX`` is ``dI/du du/dX dX``:
the bilinear interpolant's slope (from the same four pixels as the sample), the projection's
Jacobian with the lens distortion (:func:`~photomodel.fitness._kernels._project_jacobian`)
and the map's derivative. An inner-ring point that expects its colour mixed with the table
seen at its band point (the edge mixture) also moves with that band point's sample. One pose
evaluated this way replaces the pose and its forward differences (seven or ten residual
poses) and the products of :func:`~photomodel.search._gauss_newton._weighted_products`.

The same pass sums what the light offsets need to follow the pose: the Hessian in the offsets
of the objective they maximise and its cross derivative with the genes, and each camera term's
derivative in its offsets (``SoftFitness.normal_equations(with_offsets=True)``).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from photomodel.fitness._kernels import _project_jacobian, exp_neg
from photomodel.fitness._soft_kernels import _LOGS, _OPPONENT, _bilinear_cell, _light_gain


@njit(cache=True, inline="always", fastmath=True, error_model="numpy")
def _bilinear_slope(img, u, v, out, du, dv):  # pragma: no cover - compiled
    """``_bilinear`` of ``img`` at (u, v) into ``out``, and its slopes ``du``, ``dv`` (3,)."""
    iu, iv, fu, fv = _bilinear_cell(img, u, v)
    if iu < 0:
        return False
    for c in range(3):
        a = img[iv, iu, c]
        b = img[iv, iu + 1, c]
        p = img[iv + 1, iu, c]
        q = img[iv + 1, iu + 1, c]
        top = a * (1.0 - fu) + b * fu
        bottom = p * (1.0 - fu) + q * fu
        out[c] = top * (1.0 - fv) + bottom * fv
        du[c] = (b - a) * (1.0 - fv) + (q - p) * fv
        dv[c] = bottom - top
    return True


@njit(cache=True, inline="always", fastmath=True, error_model="numpy")
def _sample_jacobian(M, t, dX, K, D, x, y, img, out, du, dv, moved, jac):  # pragma: no cover
    """``out`` = the sample of ``img`` where model point (x, y) lies under the map (M, t)
    (camera point ``M[:, :2] (x, y) + t``), ``du``, ``dv`` its slopes along the image axes
    and ``moved`` (2, G) the pixel's motion (u, v) along each gene, whose camera point moves
    by ``dX[g, :, 0] x + dX[g, :, 1] y + dX[g, :, 2]``: the sample's derivative is ``du
    moved[0] + dv moved[1]``. False outside the image."""
    X = M[0, 0] * x + M[0, 1] * y + t[0]
    Y = M[1, 0] * x + M[1, 1] * y + t[1]
    Z = M[2, 0] * x + M[2, 1] * y + t[2]
    u, v = _project_jacobian(X, Y, Z, K, D, jac)
    if not _bilinear_slope(img, u, v, out, du, dv):
        return False
    for g in range(dX.shape[0]):
        moved_u = 0.0
        moved_v = 0.0
        for i in range(3):
            d = dX[g, i, 0] * x + dX[g, i, 1] * y + dX[g, i, 2]
            moved_u += jac[0, i] * d
            moved_v += jac[1, i] * d
        moved[0, g] = moved_u
        moved[1, g] = moved_v
    return True


@njit(cache=True, inline="always", fastmath=True, error_model="numpy")
def _mixture_slope(model_lin, gain, table, t, out, slope):  # pragma: no cover - compiled
    """``_edge_mixture`` into ``out``, and ``slope`` (3, 3) = d out / d table: log channel
    ``k`` mixes ``(1 - t) model gain + t exp(w_k)``, ``w_k`` the table's log channel."""
    for c in range(3):
        out[c] = 0.0
        for j in range(3):
            slope[c, j] = 0.0
    for k in range(3):
        w = 0.0
        for j in range(3):
            w += _LOGS[k, j] * table[j]
        seen = t * np.exp(w)
        total = (1.0 - t) * model_lin[k] * gain[k] + seen
        mixed = np.log(total)
        share = seen / total
        for c in range(3):
            out[c] += _OPPONENT[c, k] * mixed
            for j in range(3):
                slope[c, j] += _OPPONENT[c, k] * share * _LOGS[k, j]


@njit(cache=True, inline="always", fastmath=True, error_model="numpy")
def _agreement(r):  # pragma: no cover - compiled
    """A sample's agreement ``exp(-|r|^2 / 2)`` from its scaled residual ``r`` (3,)."""
    return exp_neg(0.5 * (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]))


@njit(cache=True, inline="always", fastmath=True, error_model="numpy")
def _accumulate(r, coef, basis, k, scale, w, inner, pair, lead, gradient,
                metric):  # pragma: no cover - compiled
    """Add one sample's ``-J^T (w r)`` to ``gradient`` and, for an inner point, ``w J^T J``
    to the lower triangle of ``metric``. Its Jacobian is low-rank, row ``c`` of ``J`` being
    ``scale[c] sum_i coef[c, i] basis[i]`` over the first ``k`` rows of ``basis`` (G,) (the
    pixel motions of the sample, and of its band point for an edge mixture); ``w`` is its
    agreement (:func:`_agreement`) times its weight. ``pair`` (4, 4) and ``lead`` (4,) are
    work space."""
    G = basis.shape[1]
    for i in range(k):
        along = 0.0
        for c in range(3):
            along += scale[c] * coef[c, i] * r[c]
        along *= w
        for p in range(G):
            gradient[p] -= along * basis[i, p]
    if not inner:
        return
    for i in range(k):
        for m in range(k):
            s = 0.0
            for c in range(3):
                s += scale[c] * scale[c] * coef[c, i] * coef[c, m]
            pair[i, m] = w * s
    for p in range(G):
        for i in range(k):
            s = 0.0
            for m in range(k):
                s += pair[i, m] * basis[m, p]
            lead[i] = s
        for q in range(p + 1):
            s = 0.0
            for i in range(k):
                s += lead[i] * basis[i, q]
            metric[p, q] += s


@njit(cache=True, fastmath=True, error_model="numpy")
def _camera_normal_equations(M, t, dX, K, D, p_in, f_in, p_out, f_out, img, scale, table_out,
                             mix_t, lin_in, o, weights, wb_weight, band, band_slope, band_moved,
                             band_ok, gradient, metric, hess_o, cross_o,
                             slope_o):  # pragma: no cover - compiled
    """One camera's ``gradient`` (G,) and ``metric`` (G, G) at fixed light offsets ``o``, and
    the offsets' terms ``hess_o`` (3, 3), ``cross_o`` (3, G), ``slope_o`` (3) (see
    :func:`soft_normal_kernel`); ``band`` and ``band_slope`` (N_out, 3, 2), ``band_moved``
    (N_out, 2, G) and ``band_ok`` are work space."""
    n_in = p_in.shape[0]
    n_out = p_out.shape[0]
    G = dX.shape[0]
    W = np.empty(3)
    e = np.empty(3)
    we = np.empty(3)
    for c in range(3):
        W[c] = scale[c] * scale[c]
    sample = np.empty(3)
    du = np.empty(3)
    dv = np.empty(3)
    jac = np.empty((2, 3))
    r = np.empty(3)
    coef = np.empty((3, 4))
    basis = np.empty((4, G))
    pair = np.empty((4, 4))
    lead = np.empty(4)
    expected = np.empty(3)
    slope = np.empty((3, 3))
    gain = np.empty(3)
    _light_gain(o, gain)
    for j in range(p_out.shape[0]):    # the band first: the inner ring's mixture needs it
        ok = _sample_jacobian(M, t, dX, K, D, p_out[j, 0], p_out[j, 1], img, sample, du, dv,
                              basis[:2], jac)
        band_ok[j] = ok
        if not ok:
            continue
        for c in range(3):
            band[j, c] = sample[c]
            r[c] = (sample[c] - f_out[j, c] - o[c]) * scale[c]
            coef[c, 0] = band_slope[j, c, 0] = du[c]
            coef[c, 1] = band_slope[j, c, 1] = dv[c]
        for g in range(G):
            band_moved[j, 0, g] = basis[0, g]
            band_moved[j, 1, g] = basis[1, g]
        a = _agreement(r)
        _accumulate(r, coef, basis, 2, scale, a * weights[n_in + j], False, pair, lead,
                    gradient, metric)
        # d (band agreement) / d o = a W e, e = sample - colour - o; the band counts against.
        for c in range(3):
            slope_o[c] -= a * scale[c] * r[c] / n_out
    for j in range(n_in):
        if not _sample_jacobian(M, t, dX, K, D, p_in[j, 0], p_in[j, 1], img, sample, du, dv,
                                basis[:2], jac):
            continue
        for c in range(3):
            coef[c, 0] = du[c]
            coef[c, 1] = dv[c]
        # The offsets maximise the mean agreement of the plain differences (less the chroma
        # penalty): its Hessian in o and its cross derivative with the genes.
        d2 = 0.0
        for c in range(3):
            e[c] = sample[c] - f_in[j, c] - o[c]
            we[c] = W[c] * e[c]
            d2 += e[c] * we[c]
        plain = exp_neg(0.5 * d2)     # the agreement of the plain difference
        a = plain / n_in
        for c in range(3):
            for m in range(3):
                hess_o[c, m] += a * we[c] * we[m]
            hess_o[c, c] -= a * W[c]
            # a W (I - e e^T W) d sample / d gene, the sample's derivative du u' + dv v'
            row_u = a * (W[c] * du[c] - we[c] * (we[0] * du[0] + we[1] * du[1] + we[2] * du[2]))
            row_v = a * (W[c] * dv[c] - we[c] * (we[0] * dv[0] + we[1] * dv[1] + we[2] * dv[2]))
            for g in range(G):
                cross_o[c, g] += row_u * basis[0, g] + row_v * basis[1, g]
        k = table_out[j]
        rank = 2
        if mix_t > 0.0 and k >= 0 and band_ok[k]:
            # The expected colour moves with the band's sample: d expected = slope d band.
            _mixture_slope(lin_in[j], gain, band[k], mix_t, expected, slope)
            for c in range(3):
                r[c] = (sample[c] - expected[c]) * scale[c]
                for i in range(2):
                    coef[c, 2 + i] = -(slope[c, 0] * band_slope[k, 0, i]
                                       + slope[c, 1] * band_slope[k, 1, i]
                                       + slope[c, 2] * band_slope[k, 2, i])
            for g in range(G):
                basis[2, g] = band_moved[k, 0, g]
                basis[3, g] = band_moved[k, 1, g]
            rank = 4
            # d expected / d o = I - slope (the offsets' gain on the model's share)
            a = _agreement(r)
            for m in range(3):
                for c in range(3):
                    slope_o[m] += (a / n_in * scale[c] * r[c]
                                   * ((1.0 if c == m else 0.0) - slope[c, m]))
        else:     # the plain difference: its agreement is the offsets' one above
            for c in range(3):
                r[c] = e[c] * scale[c]
            a = plain
            for c in range(3):
                slope_o[c] += a / n_in * scale[c] * r[c]
        _accumulate(r, coef, basis, rank, scale, a * weights[j], weights[j] > 0.0, pair, lead,
                    gradient, metric)
    for p in range(G):
        for q in range(p):
            metric[q, p] = metric[p, q]
    for c in (1, 2):     # the chroma penalty wb (o_a^2 + o_b^2)
        hess_o[c, c] -= 2.0 * wb_weight
        slope_o[c] -= 2.0 * wb_weight * o[c]


@njit(cache=True, parallel=True, fastmath=True, error_model="numpy")
def soft_normal_kernel(Ms, ts, dXs, K1, D1, K2, D2, p_in, f_in, p_out, f_out, img1, img2,
                       scale_l, scale_c, table_out, mix_t, lin_in, offsets, weights, wb_weight,
                       out_gradient, out_metric, out_hess_o, out_cross_o,
                       out_slope_o):  # pragma: no cover - compiled
    """Fill ``out_gradient`` (2, G) and ``out_metric`` (2, G, G) with each camera's held-offset
    gradient ``-sum_j w_j J_j^T r_j`` and inner metric ``sum_inner w_j J_j^T J_j``.

    With the offsets: ``out_hess_o`` (2, 3, 3) and ``out_cross_o`` (2, 3, G), the Hessian in
    the offsets of each camera's offset objective (the mean agreement of the inner points'
    plain differences less the chroma penalty, which the offsets maximise) and its cross
    derivative with the genes, and ``out_slope_o`` (2, 3) the camera term's derivative in its
    offsets: the offsets move with the pose by ``-hess^-1 cross`` (the implicit function
    theorem), and the term with them by ``slope_o`` times that.

    ``Ms`` (2, 3, 3) and ``ts`` (2, 3) map model points into each camera (``Ms[c][:, :2]``
    used), ``dXs`` (2, G, 3, 3) the camera point's derivative along each gene (coefficients
    of the model point's x, y and 1); ``offsets`` (2, 3) the held light offsets; ``weights``
    (N_in + N_out,) the signed weights of :meth:`SoftFitness.residual_weights`; ``w_j`` a
    sample's weight times its agreement ``exp(-|r_j|^2 / 2)``. The two cameras run side by
    side; each sums its samples in a fixed order (the same on any thread count).
    """
    n_out = p_out.shape[0]
    G = dXs.shape[1]
    scale = np.array([scale_l, scale_c, scale_c])
    for cam in prange(2):
        band = np.empty((n_out, 3))
        band_slope = np.empty((n_out, 3, 2))
        band_moved = np.empty((n_out, 2, G))
        band_ok = np.empty(n_out, dtype=np.bool_)
        if cam == 0:
            _camera_normal_equations(Ms[0], ts[0], dXs[0], K1, D1, p_in, f_in, p_out, f_out,
                                     img1, scale, table_out, mix_t, lin_in, offsets[0],
                                     weights, wb_weight, band, band_slope, band_moved,
                                     band_ok, out_gradient[0], out_metric[0],
                                     out_hess_o[0], out_cross_o[0], out_slope_o[0])
        else:
            _camera_normal_equations(Ms[1], ts[1], dXs[1], K2, D2, p_in, f_in, p_out, f_out,
                                     img2, scale, table_out, mix_t, lin_in, offsets[1],
                                     weights, wb_weight, band, band_slope, band_moved,
                                     band_ok, out_gradient[1], out_metric[1],
                                     out_hess_o[1], out_cross_o[1], out_slope_o[1])
