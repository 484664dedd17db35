"""Numba kernel of the ``soft`` residuals' normal equations, with their analytic Jacobian.

A residual is a bilinear sample of a smoothed feature image less the colour the model expects
there (:func:`~photomodel.fitness._soft_kernels._camera_residuals`). Its derivative with
respect to a gene that moves the sample's camera point ``X`` by ``dX`` is ``dI/du du/dX dX``:
the bilinear interpolant's slope (from the same four pixels as the sample), the projection's
Jacobian with the lens distortion (:func:`~photomodel.fitness._kernels._projection_jacobian`)
and the map's derivative. An inner-ring point that expects its colour mixed with the table
seen at its band point (the edge mixture) also moves with that band point's sample.

The camera point of model point ``q = (x, y, 1)`` moves along gene ``g`` by ``dX[g] q``, so a
residual row is ``a (x) q`` (``a`` (3,): the colour's slope through the projection's Jacobian)
times the fixed matrix ``D`` (9, G) of the genes' ``dX``: the sums run in this 9-dimensional
space, one ``D`` product per call, and a plain inner point's ``sum_c w J_c^T J_c`` is the
Kronecker product ``(w sum_c a_c a_c^T) (x) q q^T`` (36 products, against about 190 in the
genes' own form).

The same pass sums what the light offsets need to follow the pose: the Hessian in the offsets
of the objective they maximise and its cross derivative with the genes, and each camera term's
derivative in its offsets (``SoftFitness.normal_equations(with_offsets=True)``).
"""

from __future__ import annotations

import numpy as np
from numba import prange
from numba.extending import overload

from photomodel._jit import njit
from photomodel.fitness._kernels import exp_neg, plane_pixel_jacobians
from photomodel.fitness._protocols import kernel_normal_equations
from photomodel.fitness._soft_kernels import (
    _LOGS,
    _OPPONENT,
    _bilinear_cell,
    _light_gain,
    mixed_features,
    ring_mixtures,
    ring_size,
    soft_args_type,
)


@njit(inline="always", fastmath=True, error_model="numpy")
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


@njit(inline="always", fastmath=True, error_model="numpy")
def _sample_slope(proj, j, img, out, du, dv, jac):  # pragma: no cover - compiled
    """``out`` = the sample of ``img`` at point ``j``'s pixel, ``du``, ``dv`` its slopes
    along the image axes and ``jac`` (2, 3) the pixel's motion with the camera point, from
    the points' projections ``proj`` (8, N) (:func:`~photomodel.fitness._kernels.
    plane_pixel_jacobians`). False outside the image."""
    for i in range(3):
        jac[0, i] = proj[2 + i, j]
        jac[1, i] = proj[5 + i, j]
    return _bilinear_slope(img, proj[0, j], proj[1, j], out, du, dv)


@njit(inline="always", fastmath=True, error_model="numpy")
def _add_outer(acc, a, x, y, f):  # pragma: no cover - compiled
    """``acc`` (9,) += ``f a (x) (x, y, 1)``, ``a`` (3,): a row in the model point's
    9-dimensional space (index ``3 i + b``: camera axis ``i``, model coordinate ``b``)."""
    for i in range(3):
        s = f * a[i]
        acc[3 * i] += s * x
        acc[3 * i + 1] += s * y
        acc[3 * i + 2] += s


@njit(inline="always", fastmath=True, error_model="numpy")
def _add_gradient(g9, r, scale, du, dv, jac, x, y, w, a3):  # pragma: no cover - compiled
    """``g9`` (9,) -= ``w J^T r`` of a sample whose residual ``r`` (3,) moves with its own
    pixel only (slopes ``du``, ``dv``, projection Jacobian ``jac`` (2, 3), model point (x, y)):
    row ``c`` of ``J`` is ``scale_c (du_c jac_u + dv_c jac_v) (x) (x, y, 1)``. ``a3`` (3,) is
    work space."""
    al0 = 0.0
    al1 = 0.0
    for c in range(3):
        al0 += scale[c] * du[c] * r[c]
        al1 += scale[c] * dv[c] * r[c]
    for i in range(3):
        a3[i] = al0 * jac[0, i] + al1 * jac[1, i]
    _add_outer(g9, a3, x, y, -w)


@njit(inline="always", fastmath=True, error_model="numpy")
def _mixture_slope(work, j, model_lin, gain, t, out, slope):  # pragma: no cover - compiled
    """Ring point ``j``'s edge mixture in ``work`` (:func:`ring_mixtures`) into ``out``, and
    ``slope`` (3, 3) = d out / d table: log channel ``k`` mixes ``(1 - t) model gain + t
    exp(w_k)``, ``w_k`` the table's log channel, so it moves by the table's share of it."""
    mixed_features(work, j, out)
    n = work.shape[1] // 3
    for c in range(3):
        for i in range(3):
            slope[c, i] = 0.0
    for k in range(3):
        seen = work[2, k * n + j]
        share = seen / ((1.0 - t) * model_lin[k] * gain[k] + seen)
        for c in range(3):
            for i in range(3):
                slope[c, i] += _OPPONENT[c, k] * share * _LOGS[k, i]


@njit(inline="always", fastmath=True, error_model="numpy")
def _agreement(r):  # pragma: no cover - compiled
    """A sample's agreement ``exp(-|r|^2 / 2)`` from its scaled residual ``r`` (3,)."""
    return exp_neg(0.5 * (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]))


@njit(fastmath=True, error_model="numpy")
def _to_genes(dX, g9, m9, kron, cross9, gradient, metric, cross_o):  # pragma: no cover
    """Add the sums of the model point's 9-dimensional space to the genes' ``gradient`` (G,),
    ``metric`` (G, G) and ``cross_o`` (3, G): ``D^T g9``, ``D^T (m9 + kron) D`` and
    ``cross9 D``, with ``D[3 i + b, g] = dX[g, i, b]``. ``m9`` (9, 9) holds its lower
    triangle; ``kron`` (6, 6) the Kronecker sums ``P (x) Q`` by the unique entries of the
    symmetric 3 x 3 factors (``i (i + 1) / 2 + j`` for ``i >= j``)."""
    G = dX.shape[0]
    full = np.empty((9, 9))
    for z in range(9):
        i, b = z // 3, z % 3
        for zz in range(z + 1):
            ii, bb = zz // 3, zz % 3
            p = i * (i + 1) // 2 + ii
            q = max(b, bb) * (max(b, bb) + 1) // 2 + min(b, bb)
            full[z, zz] = full[zz, z] = m9[z, zz] + kron[p, q]
    D = np.empty((9, G))
    for z in range(9):
        for g in range(G):
            D[z, g] = dX[g, z // 3, z % 3]
    half = np.zeros((9, G))     # full D, summed in a fixed order (not BLAS: thread-free)
    for z in range(9):
        for zz in range(9):
            for g in range(G):
                half[z, g] += full[z, zz] * D[zz, g]
    for g in range(G):
        for z in range(9):
            gradient[g] += D[z, g] * g9[z]
            for c in range(3):
                cross_o[c, g] += D[z, g] * cross9[c, z]
        for gg in range(g + 1):
            s = 0.0
            for z in range(9):
                s += D[z, g] * half[z, gg]
            metric[g, gg] += s
            if gg < g:
                metric[gg, g] += s


_BLOCK = 128
"""Interior points a block of :func:`_plain_sums`; its work space is ``_ROWS`` rows of it."""
_ROWS = 47
# The rows of _plain_sums' work space: (x, y, 1) of the model point, whether its sample
# fell inside the image, the plain differences e and the samples' slopes along the image
# axes by channel; then the products: the offsets' cross rows a3 (channel, axis) and
# -w J^T r's (axis), the inner metric's factors by unique entries, a W e and W e, a.
_Q, _OK, _E, _DU, _DV, _L, _PU, _QU, _AW, _WE, _A = 0, 3, 4, 7, 10, 13, 28, 34, 40, 43, 46


@njit(inline="always", fastmath=True, error_model="numpy")
def _dot_rows(work, r1, r2, n):  # pragma: no cover - compiled
    """The sum over the block's ``n`` points of rows ``r1`` and ``r2``' products."""
    s = 0.0
    for m in range(n):
        s += work[r1 * _BLOCK + m] * work[r2 * _BLOCK + m]
    return s


@njit(fastmath=True, error_model="numpy")
def _plain_sums(j0, j1, proj, img, xy_in, f_in, o, W, weights, n_in, work, g9, kron, cross9,
                hess, slope_sum):  # pragma: no cover - compiled
    """The sums of :func:`_camera_normal_equations`' point loop over inner points ``j0`` to
    ``j1`` whose residual is the plain difference (no edge mixture): ``g9``, ``kron``,
    ``cross9``, ``hess`` and ``slope_sum`` as that loop adds them, in blocks of ``_BLOCK``
    points laid out by point (``work`` (_ROWS * _BLOCK,)): the samples one point at a time,
    then the per-point products and the sums over the block as passes that vectorise (one
    flat array whose rows lie a constant ``_BLOCK`` apart, so that the compiler sees the
    passes' writes never meet their reads)."""
    B = _BLOCK
    sample = np.empty(3)
    du = np.empty(3)
    dv = np.empty(3)
    acc = np.zeros((15, 3))
    sum_a = 0.0
    for b0 in range(j0, j1, B):
        n = min(B, j1 - b0)
        for m in range(n):
            j = b0 + m
            inside = _bilinear_slope(img, proj[0, j], proj[1, j], sample, du, dv)
            work[_OK * B + m] = 1.0 if inside else 0.0
            for c in range(3):
                work[(_E + c) * B + m] = sample[c] - f_in[j, c] - o[c] if inside else 0.0
                work[(_DU + c) * B + m] = du[c] if inside else 0.0
                work[(_DV + c) * B + m] = dv[c] if inside else 0.0
            work[_Q * B + m] = xy_in[0, j]
            work[(_Q + 1) * B + m] = xy_in[1, j]
            work[(_Q + 2) * B + m] = 1.0
        for m in range(n):
            j = b0 + m
            e0 = work[_E * B + m]
            e1 = work[(_E + 1) * B + m]
            e2 = work[(_E + 2) * B + m]
            we0 = W[0] * e0
            we1 = W[1] * e1
            we2 = W[2] * e2
            plain = work[_OK * B + m] * exp_neg(0.5 * (e0 * we0 + e1 * we1 + e2 * we2))
            a = plain / n_in
            w = plain * weights[j]
            inner = w if weights[j] > 0.0 else 0.0
            du0 = work[_DU * B + m]
            du1 = work[(_DU + 1) * B + m]
            du2 = work[(_DU + 2) * B + m]
            dv0 = work[_DV * B + m]
            dv1 = work[(_DV + 1) * B + m]
            dv2 = work[(_DV + 2) * B + m]
            wdu = we0 * du0 + we1 * du1 + we2 * du2
            wdv = we0 * dv0 + we1 * dv1 + we2 * dv2
            work[_A * B + m] = a
            work[_AW * B + m] = a * we0
            work[(_AW + 1) * B + m] = a * we1
            work[(_AW + 2) * B + m] = a * we2
            work[_WE * B + m] = we0
            work[(_WE + 1) * B + m] = we1
            work[(_WE + 2) * B + m] = we2
            # the offsets' cross rows a3 (c, i) = a W_c (I - e e^T W) d sample / d pixel . jac
            u0 = a * (W[0] * du0 - we0 * wdu)
            u1 = a * (W[1] * du1 - we1 * wdu)
            u2 = a * (W[2] * du2 - we2 * wdu)
            v0 = a * (W[0] * dv0 - we0 * wdv)
            v1 = a * (W[1] * dv1 - we1 * wdv)
            v2 = a * (W[2] * dv2 - we2 * wdv)
            ju0 = proj[2, j]
            ju1 = proj[3, j]
            ju2 = proj[4, j]
            jv0 = proj[5, j]
            jv1 = proj[6, j]
            jv2 = proj[7, j]
            work[_L * B + m] = u0 * ju0 + v0 * jv0
            work[(_L + 1) * B + m] = u0 * ju1 + v0 * jv1
            work[(_L + 2) * B + m] = u0 * ju2 + v0 * jv2
            work[(_L + 3) * B + m] = u1 * ju0 + v1 * jv0
            work[(_L + 4) * B + m] = u1 * ju1 + v1 * jv1
            work[(_L + 5) * B + m] = u1 * ju2 + v1 * jv2
            work[(_L + 6) * B + m] = u2 * ju0 + v2 * jv0
            work[(_L + 7) * B + m] = u2 * ju1 + v2 * jv1
            work[(_L + 8) * B + m] = u2 * ju2 + v2 * jv2
            work[(_L + 9) * B + m] = -w * (wdu * ju0 + wdv * jv0)
            work[(_L + 10) * B + m] = -w * (wdu * ju1 + wdv * jv1)
            work[(_L + 11) * B + m] = -w * (wdu * ju2 + wdv * jv2)
            # J row c = a_c (x) q, a_c = scale_c (du_c jac_u + dv_c jac_v): the inner metric
            # (w sum_c a_c a_c^T) (x) q q^T by the factors' unique entries.
            p0 = 0.0
            p1 = 0.0
            p2 = 0.0
            p3 = 0.0
            p4 = 0.0
            p5 = 0.0
            for c in range(3):
                dc = work[(_DU + c) * B + m]
                ec = work[(_DV + c) * B + m]
                a0 = dc * ju0 + ec * jv0
                a1 = dc * ju1 + ec * jv1
                a2 = dc * ju2 + ec * jv2
                f = inner * W[c]
                p0 += f * a0 * a0
                p1 += f * a1 * a0
                p2 += f * a1 * a1
                p3 += f * a2 * a0
                p4 += f * a2 * a1
                p5 += f * a2 * a2
            work[_PU * B + m] = p0
            work[(_PU + 1) * B + m] = p1
            work[(_PU + 2) * B + m] = p2
            work[(_PU + 3) * B + m] = p3
            work[(_PU + 4) * B + m] = p4
            work[(_PU + 5) * B + m] = p5
            x = work[_Q * B + m]
            y = work[(_Q + 1) * B + m]
            work[_QU * B + m] = x * x
            work[(_QU + 1) * B + m] = y * x
            work[(_QU + 2) * B + m] = y * y
            work[(_QU + 3) * B + m] = x
            work[(_QU + 4) * B + m] = y
            work[(_QU + 5) * B + m] = 1.0
        for r in range(15):
            for b in range(3):
                acc[r, b] += _dot_rows(work, _L + r, _Q + b, n)
        for k in range(6):
            for kk in range(6):
                kron[k, kk] += _dot_rows(work, _PU + k, _QU + kk, n)
        for c in range(3):
            slope_sum[c] += _dot_rows(work, _AW + c, _Q + 2, n)
            for mm in range(3):
                hess[c, mm] += _dot_rows(work, _AW + c, _WE + mm, n)
        sum_a += _dot_rows(work, _A, _Q + 2, n)
    for c in range(3):
        hess[c, c] -= W[c] * sum_a
        for i in range(3):
            for b in range(3):
                cross9[c, 3 * i + b] += acc[3 * c + i, b]
    for i in range(3):
        for b in range(3):
            g9[3 * i + b] += acc[9 + i, b]


@njit(fastmath=True, error_model="numpy")
def _camera_normal_equations(M, t, dX, K, D, xy_in, f_in, xy_out, f_out, img, scale,
                             table_out, mix_t, lin_in, o, weights, wb_weight, band,
                             band_slope, band_jac, band_ok, proj, mix_work, plain_work,
                             gradient, metric, hess_o, cross_o,
                             slope_o):  # pragma: no cover - compiled
    """One camera's ``gradient`` (G,) and ``metric`` (G, G) at fixed light offsets ``o``, and
    the offsets' terms ``hess_o`` (3, 3), ``cross_o`` (3, G), ``slope_o`` (3) (see
    :func:`soft_normal_equations`), summed in the model point's 9-dimensional space (the module
    docstring) and taken to the genes at the end; ``band`` (N_out, 3), ``band_slope`` (N_out,
    3, 2), ``band_jac`` (N_out, 2, 3) and ``band_ok`` are work space: a band point's sample,
    its slopes and its projection's Jacobian, for the inner ring's edge mixture; ``proj``
    (8, max(N_in, N_out)) too: the points' pixels and their Jacobians, one loop each set;
    ``mix_work`` (4, 3 ring_size(table_out)) the edge mixtures' (:func:`ring_mixtures`) and
    ``plain_work`` (_ROWS * _BLOCK,) :func:`_plain_sums`' (the points after the ring, or all
    of them without the mixture)."""
    n_in = xy_in.shape[1]
    n_out = xy_out.shape[1]
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
    expected = np.empty(3)
    slope = np.empty((3, 3))
    gain = np.empty(3)
    a3 = np.empty(3)
    b3 = np.empty(3)
    y9 = np.empty((3, 9))
    g9 = np.zeros(9)
    kron = np.zeros((6, 6))      # rank-2 inner points: sum w P (x) Q by unique entries
    m9 = np.zeros((9, 9))        # the others: lower triangle
    cross9 = np.zeros((3, 9))
    pu = np.empty(6)
    qu = np.empty(6)
    q3 = np.ones(3)
    # The offsets' sums in this thread's own arrays, added to the outputs at the end: the
    # two cameras' outputs share a cache line, which summing into them point by point from
    # two threads would contend for.
    hess = np.zeros((3, 3))
    slope_sum = np.zeros(3)
    _light_gain(o, gain)
    plane_pixel_jacobians(M, t, K, D, xy_out, proj)
    for j in range(n_out):    # the band first: the inner ring's mixture needs it
        ok = _sample_slope(proj, j, img, sample, du, dv, jac)
        band_ok[j] = ok
        if not ok:
            continue
        for c in range(3):
            band[j, c] = sample[c]
            r[c] = (sample[c] - f_out[j, c] - o[c]) * scale[c]
            band_slope[j, c, 0] = du[c]
            band_slope[j, c, 1] = dv[c]
        for i in range(3):
            band_jac[j, 0, i] = jac[0, i]
            band_jac[j, 1, i] = jac[1, i]
        a = _agreement(r)
        _add_gradient(g9, r, scale, du, dv, jac, xy_out[0, j], xy_out[1, j],
                      a * weights[n_in + j], a3)
        for c in range(3):
            slope_sum[c] -= a * scale[c] * r[c] / n_out
    ring = 0     # the inner ring, where the edge mixture may apply, one point at a time
    if mix_t > 0.0:
        ring_mixtures(lin_in, gain, table_out, band, band_ok, mix_t, mix_work)
        ring = mix_work.shape[1] // 3
    plane_pixel_jacobians(M, t, K, D, xy_in, proj)
    _plain_sums(ring, n_in, proj, img, xy_in, f_in, o, W, weights, n_in, plain_work, g9, kron,
                cross9, hess, slope_sum)
    for j in range(ring):
        x = xy_in[0, j]
        y = xy_in[1, j]
        if not _sample_slope(proj, j, img, sample, du, dv, jac):
            continue
        # The offsets maximise the mean agreement of the plain differences (less the chroma
        # penalty): its Hessian in o and its cross derivative with the genes.
        d2 = 0.0
        for c in range(3):
            e[c] = sample[c] - f_in[j, c] - o[c]
            we[c] = W[c] * e[c]
            d2 += e[c] * we[c]
        plain = exp_neg(0.5 * d2)     # the agreement of the plain difference
        a = plain / n_in
        wdu = we[0] * du[0] + we[1] * du[1] + we[2] * du[2]
        wdv = we[0] * dv[0] + we[1] * dv[1] + we[2] * dv[2]
        for c in range(3):
            for m in range(3):
                hess[c, m] += a * we[c] * we[m]
            hess[c, c] -= a * W[c]
            # a W (I - e e^T W) d sample / d gene, the sample's derivative du u' + dv v'
            row_u = a * (W[c] * du[c] - we[c] * wdu)
            row_v = a * (W[c] * dv[c] - we[c] * wdv)
            for i in range(3):
                a3[i] = row_u * jac[0, i] + row_v * jac[1, i]
            _add_outer(cross9[c], a3, x, y, 1.0)
        k = table_out[j]
        inner = weights[j] > 0.0
        if mix_t > 0.0 and k >= 0 and band_ok[k]:
            # The expected colour moves with the band's sample: d expected = slope d band;
            # d expected / d o = I - slope (the offsets' gain on the model's share).
            _mixture_slope(mix_work, j, lin_in[j], gain, mix_t, expected, slope)
            for c in range(3):
                r[c] = (sample[c] - expected[c]) * scale[c]
            a = _agreement(r)
            for m in range(3):
                for c in range(3):
                    slope_sum[m] += (a / n_in * scale[c] * r[c]
                                     * ((1.0 if c == m else 0.0) - slope[c, m]))
            w = a * weights[j]
            xb = xy_out[0, k]
            yb = xy_out[1, k]
            # row c of J in z-space: scale_c [(du_c jac0 + dv_c jac1) (x) q
            #   - (sum_m slope[c, m] band_slope[k, m, :]) . band_jac (x) q_b]
            for c in range(3):
                cu = 0.0
                cv = 0.0
                for m in range(3):
                    cu -= slope[c, m] * band_slope[k, m, 0]
                    cv -= slope[c, m] * band_slope[k, m, 1]
                for i in range(3):
                    a3[i] = scale[c] * (du[c] * jac[0, i] + dv[c] * jac[1, i])
                    b3[i] = scale[c] * (cu * band_jac[k, 0, i] + cv * band_jac[k, 1, i])
                for i in range(3):
                    y9[c, 3 * i] = a3[i] * x + b3[i] * xb
                    y9[c, 3 * i + 1] = a3[i] * y + b3[i] * yb
                    y9[c, 3 * i + 2] = a3[i] + b3[i]
            for z in range(9):
                s = 0.0
                for c in range(3):
                    s += r[c] * y9[c, z]
                g9[z] -= w * s
            if inner:
                for z in range(9):
                    for zz in range(z + 1):
                        s = 0.0
                        for c in range(3):
                            s += y9[c, z] * y9[c, zz]
                        m9[z, zz] += w * s
        else:     # the plain difference: its agreement is the offsets' one above
            for c in range(3):
                r[c] = e[c] * scale[c]
            a = plain
            for c in range(3):
                slope_sum[c] += a / n_in * scale[c] * r[c]
            w = a * weights[j]
            _add_gradient(g9, r, scale, du, dv, jac, x, y, w, a3)
            if inner:
                # J row c = a_c (x) q, a_c = scale_c (du_c jac_u + dv_c jac_v): sum_c w J_c J_c^T
                # = (w sum_c a_c a_c^T) (x) q q^T, summed by the factors' unique entries.
                for n in range(6):
                    pu[n] = 0.0
                for c in range(3):
                    for i in range(3):
                        a3[i] = du[c] * jac[0, i] + dv[c] * jac[1, i]
                    n = 0
                    for i in range(3):
                        for ii in range(i + 1):
                            pu[n] += w * W[c] * a3[i] * a3[ii]
                            n += 1
                q3[0] = x
                q3[1] = y
                n = 0
                for b in range(3):
                    for bb in range(b + 1):
                        qu[n] = q3[b] * q3[bb]
                        n += 1
                for n in range(6):
                    for nn in range(6):
                        kron[n, nn] += pu[n] * qu[nn]
    _to_genes(dX, g9, m9, kron, cross9, gradient, metric, cross_o)
    for c in range(3):
        slope_o[c] += slope_sum[c]
        for m in range(3):
            hess_o[c, m] += hess[c, m]
    for c in (1, 2):     # the chroma penalty wb (o_a^2 + o_b^2)
        hess_o[c, c] -= 2.0 * wb_weight
        slope_o[c] -= 2.0 * wb_weight * o[c]


@njit(fastmath=False, error_model="numpy")
def camera_frames(A, dA, R, T):  # pragma: no cover - compiled
    """The maps of model points into each camera and their derivatives, as
    :func:`soft_normal_equations` uses them: ``Ms`` (2, 3, 3) and ``ts`` (2, 3), the linear
    part and translation of ``A`` (4, 4) (camera 1) and of ``R A + T`` (camera 2), and
    ``dXs`` (2, G, 3, 3), each gene's derivative ``dA`` (G, 4, 4) of the camera point, by
    coefficient of the model point's x, y and 1 (``G`` may be 0: the maps alone, as
    ``SoftFitness.slack_sums`` takes them), in one compiled call an iteration of
    Gauss-Newton."""
    G = dA.shape[0]
    Ms = np.empty((2, 3, 3))
    ts = np.empty((2, 3))
    dXs = np.empty((2, G, 3, 3))
    for i in range(3):
        ts[0, i] = A[i, 3]
        ts[1, i] = T[i]
        for j in range(3):
            Ms[0, i, j] = A[i, j]
            ts[1, i] += R[i, j] * A[j, 3]
        for j in range(3):
            Ms[1, i, j] = R[i, 0] * A[0, j] + R[i, 1] * A[1, j] + R[i, 2] * A[2, j]
    for g in range(G):
        for i in range(3):
            for b in range(3):
                col = b if b < 2 else 3
                dXs[0, g, i, b] = dA[g, i, col]
        for i in range(3):
            for b in range(3):
                dXs[1, g, i, b] = (R[i, 0] * dXs[0, g, 0, b] + R[i, 1] * dXs[0, g, 1, b]
                                   + R[i, 2] * dXs[0, g, 2, b])
    return Ms, ts, dXs


@njit(fastmath=False, error_model="numpy")
def full_gradient(gradient, hess_o, cross_o, slope_o, with_offsets):  # pragma: no cover
    """Both cameras' gradient (2, G) summed, and with ``with_offsets`` the offsets' motion
    added: ``0.5 sum_c slope_o[c] . (-hess_o[c]^-1 cross_o[c])`` over the cameras whose
    ``hess_o`` has a condition number below 1e12 (see ``SoftFitness.normal_equations``)."""
    G = gradient.shape[1]
    total = gradient[0] + gradient[1]
    if not with_offsets:
        return total
    for c in range(2):
        if not np.linalg.cond(hess_o[c]) < 1e12:
            continue
        moved = np.linalg.solve(hess_o[c], cross_o[c])     # minus d offsets / d genes
        for g in range(G):
            total[g] -= 0.5 * (slope_o[c, 0] * moved[0, g] + slope_o[c, 1] * moved[1, g]
                               + slope_o[c, 2] * moved[2, g])
    return total



@njit(fastmath=False, error_model="numpy")
def _normal_sums(G):  # pragma: no cover - compiled
    """Zeroed sums of :func:`soft_normal_equations`' cameras: gradient (2, G), metric (2,
    G, G), offsets' Hessian (2, 3, 3), cross terms (2, 3, G) and slopes (2, 3)."""
    return (np.zeros((2, G)), np.zeros((2, G, G)), np.zeros((2, 3, 3)), np.zeros((2, 3, G)),
            np.zeros((2, 3)))


@njit(fastmath=False, error_model="numpy")
def _both_cameras(gradient, metric, hess_o, cross_o, slope_o, with_offsets):  # pragma: no cover
    """:func:`full_gradient` and the metric of both cameras (G, G)."""
    return (full_gradient(gradient, hess_o, cross_o, slope_o, with_offsets),
            metric[0] + metric[1])


@njit(parallel=True, fastmath=True, error_model="numpy")
def soft_normal_equations(A, dA, offsets, with_offsets, args):  # pragma: no cover - compiled
    """``SoftFitness.normal_equations`` of the map ``A`` (4, 4) and its derivatives ``dA`` (G,
    4, 4) at the light offsets ``offsets`` (2, 3): the gradient (G,) (with the offsets' motion
    when ``with_offsets``) and the metric (G, G). ``args`` holds the fixed arguments
    (``SoftFitness.normal_args``). Called from Python and from Gauss-Newton's numba loop
    alike.

    Each camera's held-offset gradient ``-sum_j w_j J_j^T r_j`` and inner metric
    ``sum_inner w_j J_j^T J_j`` on its own thread (:func:`_camera_normal_equations`), and with
    the offsets the Hessian in the offsets of each camera's offset objective (the mean
    agreement of the inner points' plain differences less the chroma penalty, which the
    offsets maximise) and its cross derivative with the genes, and the camera term's
    derivative in its offsets: the offsets move with the pose by ``-hess^-1 cross`` (the
    implicit function theorem), and the term with them by ``slope_o`` times that
    (:func:`full_gradient`). ``w_j`` is a sample's weight (``SoftFitness.residual_weights``)
    times its agreement ``exp(-|r_j|^2 / 2)``; each camera sums its samples in a fixed order
    (the same on any thread count)."""
    (R, T, K1, D1, K2, D2, xy_in, f_in, xy_out, f_out, img1, img2, scale_l, scale_c, table_out,
     mix_t, lin_in, weights, wb_weight) = args
    Ms, ts, dXs = camera_frames(A, dA, R, T)
    out_gradient, out_metric, out_hess_o, out_cross_o, out_slope_o = _normal_sums(dA.shape[0])
    n_out = xy_out.shape[1]
    scale = np.array([scale_l, scale_c, scale_c])
    for cam in prange(2):
        band = np.empty((n_out, 3))
        band_slope = np.empty((n_out, 3, 2))
        band_jac = np.empty((n_out, 2, 3))
        band_ok = np.empty(n_out, dtype=np.bool_)
        proj = np.empty((8, max(xy_in.shape[1], n_out)))
        mix_work = np.empty((4, 3 * ring_size(table_out)))
        plain_work = np.empty(_ROWS * _BLOCK)
        _camera_normal_equations(Ms[cam], ts[cam], dXs[cam], K1 if cam == 0 else K2,
                                 D1 if cam == 0 else D2, xy_in, f_in, xy_out, f_out,
                                 img1 if cam == 0 else img2, scale, table_out, mix_t, lin_in,
                                 offsets[cam], weights, wb_weight, band, band_slope, band_jac,
                                 band_ok, proj, mix_work, plain_work, out_gradient[cam],
                                 out_metric[cam], out_hess_o[cam], out_cross_o[cam],
                                 out_slope_o[cam])
    return _both_cameras(out_gradient, out_metric, out_hess_o, out_cross_o, out_slope_o,
                         with_offsets)


@overload(kernel_normal_equations)
def _kernel_normal_equations(A, dA, offsets, with_offsets, args):  # type: ignore[no-untyped-def]
    """The ``soft`` fitness's implementation of Gauss-Newton's ``kernel_normal_equations``."""
    if soft_args_type(args, 19, (10, 11)):
        return lambda A, dA, offsets, with_offsets, args: soft_normal_equations(
            A, dA, offsets, with_offsets, args)
    return None
