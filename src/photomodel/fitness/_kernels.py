"""Numba kernel of the paper's fitness: project, look up and vote for a whole population."""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import prange, types
from numba.extending import intrinsic

from photomodel._jit import njit

_EXP_NEG_MAX = 60.0
"""Largest argument :func:`exp_neg` evaluates (exp(-60) = 9e-27: no agreement counts)."""


@njit(inline="always", fastmath=True, error_model="numpy")
def exp_neg(y):  # pragma: no cover - compiled
    """``exp(-y)`` for ``y >= 0`` (arguments above 60 give exp(-60)), to 4e-12 relative for
    ``y < 30`` and 2e-9 below 60: ``exp(-y / 256)`` by its degree-8 Taylor polynomial,
    squared eight times.

    Plain arithmetic, so a loop of it vectorises; numba without Intel's SVML calls the
    scalar library ``exp`` once per element, and the ``soft`` fitness's light-offset passes
    (six over the inner samples a camera) are mostly exponentials.
    """
    u = min(y, _EXP_NEG_MAX) * (1.0 / 256.0)
    p = 1.0 + u * (-1.0 + u * (1.0 / 2.0 + u * (-1.0 / 6.0 + u * (1.0 / 24.0 + u * (
        -1.0 / 120.0 + u * (1.0 / 720.0 + u * (-1.0 / 5040.0 + u * (1.0 / 40320.0))))))))
    for _ in range(8):
        p = p * p
    return p


_LOG2E = 1.4426950408889634
_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
"""ln 2 in two parts: ``k * _LN2_HI`` is exact for the exponents met here."""
_MANTISSA = 0x000FFFFFFFFFFFFF
_ONE_BITS = 0x3FF0000000000000
_SQRT2 = 1.4142135623730951


@intrinsic
def _bits(typingctx, x):  # type: ignore[no-untyped-def]
    """The bits of the float64 ``x`` as an int64 (a register move, no memory)."""
    if x != types.float64:
        return None

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        return builder.bitcast(args[0], ir.IntType(64))

    return types.int64(types.float64), codegen


@intrinsic
def _from_bits(typingctx, i):  # type: ignore[no-untyped-def]
    """The float64 whose bits are the int64 ``i``."""
    if i != types.int64:
        return None

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(types.int64), codegen


@njit(fastmath=True, error_model="numpy")
def mix_logs(t, work):  # pragma: no cover - compiled
    """``work[2] = t exp(w)`` and ``work[3] = log(a + t exp(w))`` elementwise, for ``a > 0``
    in ``work[0]`` and ``w`` in ``work[1]`` (``work`` (4, n); ``w`` clipped to +-700): the
    edge mixture's exponentials and logarithms, to about 1e-14 relative (3e-14 near +-700).

    Numba without Intel's SVML calls the scalar library ``exp`` and ``log`` once per element;
    this loop is plain arithmetic and integer operations on the floats' bits (``2**k`` and
    the exponent through them, Taylor's series of ``exp`` and ``atanh``'s of ``log``), so it
    vectorises. Safe under ``fastmath``, which a caller's passes apply to what they inline
    whatever this function's own flags: no step relies on the order of additions.
    """
    for i in range(work.shape[1]):
        w = min(max(work[1, i], -700.0), 700.0)
        k = np.floor(w * _LOG2E + 0.5)          # round(w / ln 2), and 2**k from its bits
        power = _from_bits(np.int64(np.int32(k) + 1023) << 52)
        r = (w - k * _LN2_HI) - k * _LN2_LO    # |r| <= ln 2 / 2: Taylor to r**11
        p = 1.0 + r * (1.0 + r * (1.0 / 2.0 + r * (1.0 / 6.0 + r * (1.0 / 24.0 + r * (
            1.0 / 120.0 + r * (1.0 / 720.0 + r * (1.0 / 5040.0 + r * (1.0 / 40320.0 + r * (
                1.0 / 362880.0 + r * (1.0 / 3628800.0 + r * (1.0 / 39916800.0)))))))))))
        seen = t * (p * power)
        total = _bits(work[0, i] + seen)
        m = _from_bits((total & _MANTISSA) | _ONE_BITS)       # in [1, 2)
        e = np.float64(np.int32((total >> 52) - 1023))
        big = m > _SQRT2                        # m in [sqrt(2) / 2, sqrt(2)): |s| < 0.172
        m = 0.5 * m if big else m
        e = e + 1.0 if big else e
        s = (m - 1.0) / (m + 1.0)
        z = s * s                               # log m = 2 atanh s, to z**8
        q = 1.0 + z * (1.0 / 3.0 + z * (1.0 / 5.0 + z * (1.0 / 7.0 + z * (1.0 / 9.0 + z * (
            1.0 / 11.0 + z * (1.0 / 13.0 + z * (1.0 / 15.0 + z * (1.0 / 17.0))))))))
        work[2, i] = seen
        work[3, i] = e * _LN2_HI + (2.0 * s * q + e * _LN2_LO)


@njit(inline="always", error_model="numpy")
def lens_constants(K, D):  # pragma: no cover - compiled
    """A camera's matrix ``K`` (3, 3) and 12 distortion terms ``D`` as one tuple of floats
    ``(fx, skew, cx, fy, cy, k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4)``.

    A loop over points that reads ``K`` and ``D`` through arrays while it writes several
    output rows loads them again for every point (the compiler cannot tell that the rows
    it writes do not overlap them) and, with more than a few rows, does not vectorise; read
    once into this tuple before the loop, they stay in registers."""
    return (K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2], D[0], D[1], D[2], D[3], D[4], D[5],
            D[6], D[7], D[8], D[9], D[10], D[11])


@njit(inline="always", error_model="numpy")
def plane_constants(R, t):  # pragma: no cover - compiled
    """The map of model-plane points ``(x, y)`` into a camera at pose ``(R, t)`` as one tuple
    ``(R00, R01, R10, R11, R20, R21, t0, t1, t2)`` (read once before a loop over points,
    as :func:`lens_constants`)."""
    return (R[0, 0], R[0, 1], R[1, 0], R[1, 1], R[2, 0], R[2, 1], t[0], t[1], t[2])


@njit(inline="always", error_model="numpy")
def project_lens(X, Y, Z, lens):  # pragma: no cover - compiled
    """:func:`_project` through the constants ``lens`` (:func:`lens_constants`)."""
    fx, skew, cx, fy, cy, k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4 = lens
    front = Z > 0.0
    Zs = Z if front else 1.0
    x = X / Zs
    y = Y / Zs
    r2 = x * x + y * y
    radial = (1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (
        1.0 + r2 * (k4 + r2 * (k5 + r2 * k6)))
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + s1 * r2 + s2 * r2 * r2
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + s3 * r2 + s4 * r2 * r2
    u = fx * xd + skew * yd + cx
    v = fy * yd + cy
    return (u if front else -1.0e9), (v if front else -1.0e9)


@njit(inline="always", error_model="numpy")
def _project(X, Y, Z, K, D):  # pragma: no cover - compiled
    """Pixel (u, v) of the camera point (X, Y, Z) through ``K`` and the 12 rational,
    tangential and thin-prism terms ``D``; (-1e9, -1e9) behind the camera. Without a branch
    (behind the camera is a select), so that a loop of it over points vectorises."""
    return project_lens(X, Y, Z, lens_constants(K, D))


@njit(inline="always", error_model="numpy")
def projection_jacobian_lens(X, Y, Z, lens):  # pragma: no cover - compiled
    """:func:`_projection_jacobian` through the constants ``lens`` (:func:`lens_constants`)."""
    fx, skew, cx, fy, cy, k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4 = lens
    front = Z > 0.0
    iz = 1.0 / (Z if front else 1.0)
    x = X * iz
    y = Y * iz
    r2 = x * x + y * y
    num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
    radial = num / den
    # d radial / d r2, and the thin-prism terms' d / d r2
    d_radial = ((k1 + r2 * (2.0 * k2 + 3.0 * r2 * k3))
                - radial * (k4 + r2 * (2.0 * k5 + 3.0 * r2 * k6))) / den
    prism_x = s1 + 2.0 * s2 * r2
    prism_y = s3 + 2.0 * s4 * r2
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + s1 * r2 + s2 * r2 * r2
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + s3 * r2 + s4 * r2 * r2
    xd_x = radial + 2.0 * x * (x * d_radial + prism_x) + 2.0 * p1 * y + 6.0 * p2 * x
    xd_y = 2.0 * y * (x * d_radial + prism_x) + 2.0 * p1 * x + 2.0 * p2 * y
    yd_x = 2.0 * x * (y * d_radial + prism_y) + 2.0 * p1 * x + 2.0 * p2 * y
    yd_y = radial + 2.0 * y * (y * d_radial + prism_y) + 6.0 * p1 * y + 2.0 * p2 * x
    u_x = fx * xd_x + skew * yd_x
    u_y = fx * xd_y + skew * yd_y
    v_x = fy * yd_x
    v_y = fy * yd_y
    u = fx * xd + skew * yd + cx
    v = fy * yd + cy
    return ((u if front else -1.0e9), (v if front else -1.0e9), u_x * iz, u_y * iz,
            -(u_x * x + u_y * y) * iz, v_x * iz, v_y * iz, -(v_x * x + v_y * y) * iz)


@njit(inline="always", error_model="numpy")
def _projection_jacobian(X, Y, Z, K, D):  # pragma: no cover - compiled
    """``_project`` of (X, Y, Z) and d(u, v) / d(X, Y, Z), by rows: (u, v, du/dX, du/dY,
    du/dZ, dv/dX, dv/dY, dv/dZ); the same rational radial, tangential and thin-prism terms,
    differentiated in closed form. Without a branch, as ``_project``."""
    return projection_jacobian_lens(X, Y, Z, lens_constants(K, D))


@njit(inline="always", error_model="numpy")
def plane_point(plane, x, y):  # pragma: no cover - compiled
    """Camera point (X, Y, Z) of the model-plane point ``(x, y)`` through the map ``plane``
    (:func:`plane_constants`)."""
    r00, r01, r10, r11, r20, r21, t0, t1, t2 = plane
    return r00 * x + r01 * y + t0, r10 * x + r11 * y + t1, r20 * x + r21 * y + t2


@njit(inline="always", error_model="numpy")
def plane_pixel(R, t, K, D, x, y):  # pragma: no cover - compiled
    """Pixel (u, v) where the model-plane point ``(x, y)`` lies at pose ``(R, t)`` through
    camera ``K``, ``D`` (``_project``)."""
    X, Y, Z = plane_point(plane_constants(R, t), x, y)
    return project_lens(X, Y, Z, lens_constants(K, D))


@njit(inline="always", error_model="numpy")
def plane_pixels(R, t, K, D, xy, out):  # pragma: no cover - compiled
    """``out`` (2, N) = the pixels (u, v) of the model-plane points ``xy`` (2, N: their x
    and y by row) at pose ``(R, t)`` through ``K``, ``D`` (:func:`plane_pixel`; -1e9 behind
    the camera). One loop that vectorises, before the points' bilinear samples; the
    coordinates by row let it load four points' x (and y) at once."""
    plane = plane_constants(R, t)
    lens = lens_constants(K, D)
    for j in range(xy.shape[1]):
        X, Y, Z = plane_point(plane, xy[0, j], xy[1, j])
        out[0, j], out[1, j] = project_lens(X, Y, Z, lens)


@njit(inline="always", error_model="numpy")
def plane_pixel_jacobians(R, t, K, D, xy, out):  # pragma: no cover - compiled
    """``out`` (8, N) = :func:`_projection_jacobian`'s rows for the model-plane points ``xy``
    (2, N: x and y by row) at pose ``(R, t)``: the pixel and its derivative along the camera
    point, in one loop that vectorises (as :func:`plane_pixels`; the camera's constants
    read once, :func:`lens_constants`)."""
    plane = plane_constants(R, t)
    lens = lens_constants(K, D)
    for j in range(xy.shape[1]):
        X, Y, Z = plane_point(plane, xy[0, j], xy[1, j])
        (out[0, j], out[1, j], out[2, j], out[3, j], out[4, j], out[5, j], out[6, j],
         out[7, j]) = projection_jacobian_lens(X, Y, Z, lens)


@njit(inline="always")
def _matches(code_img, sat_img, code_model, min_sat, thr):  # pragma: no cover - compiled
    if code_model < 0.0:
        return code_img < 0.0
    if code_img < 0.0 or sat_img < min_sat:
        return False
    d = abs(code_img - code_model)
    if d > 180.0:
        d = 360.0 - d
    return d <= thr


@njit
def _count(R, t, K, D, pts, codes, min_sat, img, sat, thr):  # pragma: no cover - compiled
    h, w = img.shape
    n = 0
    lens = lens_constants(K, D)
    for j in range(pts.shape[0]):
        X = R[0, 0] * pts[j, 0] + R[0, 1] * pts[j, 1] + R[0, 2] * pts[j, 2] + t[0]
        Y = R[1, 0] * pts[j, 0] + R[1, 1] * pts[j, 1] + R[1, 2] * pts[j, 2] + t[1]
        Z = R[2, 0] * pts[j, 0] + R[2, 1] * pts[j, 1] + R[2, 2] * pts[j, 2] + t[2]
        u, v = project_lens(X, Y, Z, lens)
        iu = int(np.floor(u + 0.5))
        iv = int(np.floor(v + 0.5))
        if iu < 0 or iv < 0 or iu >= w or iv >= h:
            continue
        if _matches(img[iv, iu], sat[iv, iu], codes[j], min_sat[j], thr):
            n += 1
    return n


@njit(inline="always")
def camera2_pose(R1, t1, R21, T21):  # pragma: no cover - compiled
    """Model pose in camera 2, (R2, t2), from the pose (R1, t1) in camera 1 and the rig's
    ``X2 = R21 X1 + T21``."""
    R2 = np.empty((3, 3))
    t2 = np.empty(3)
    for i in range(3):
        t2[i] = T21[i]
        for k in range(3):
            t2[i] += R21[i, k] * t1[k]
            R2[i, k] = R21[i, 0] * R1[0, k] + R21[i, 1] * R1[1, k] + R21[i, 2] * R1[2, k]
    return R2, t2


@njit(parallel=True)
def paper_fitness_kernel(Rs, ts, R21, T21, K1, D1, K2, D2, p_in, c_in, s_in, p_out, c_out,
                         s_out, img1, sat1, img2, sat2, thr, vote_in, vote_out, out_f, out_counts
                         ):  # pragma: no cover - compiled
    """Fill ``out_f`` (P,) with eq. (9) and ``out_counts`` (P, 4) with the match counts.

    ``c_*`` are the model points' hue codes and ``s_*`` the least image saturation each
    accepts; ``img*`` are hue-code images and ``sat*`` saturation images.

    Counts per pose: [S_in matches cam 1, S_out matches cam 1, S_in cam 2, S_out cam 2].
    """
    for p in prange(Rs.shape[0]):
        R1 = Rs[p]
        t1 = ts[p]
        R2, t2 = camera2_pose(R1, t1, R21, T21)
        a = _count(R1, t1, K1, D1, p_in, c_in, s_in, img1, sat1, thr)
        b = _count(R1, t1, K1, D1, p_out, c_out, s_out, img1, sat1, thr)
        c = _count(R2, t2, K2, D2, p_in, c_in, s_in, img2, sat2, thr)
        d = _count(R2, t2, K2, D2, p_out, c_out, s_out, img2, sat2, thr)
        out_counts[p, 0] = a
        out_counts[p, 1] = b
        out_counts[p, 2] = c
        out_counts[p, 3] = d
        out_f[p] = ((vote_in * a - vote_out * b) + (vote_in * c - vote_out * d)) / 2.0
