"""Numba kernel of the ``soft`` fitness: project, sample bilinearly, compare colours."""

from __future__ import annotations

import numpy as np
from numba import prange, types
from numba.extending import overload

from photomodel._jit import njit
from photomodel.fitness._kernels import (
    camera2_pose,
    exp_neg,
    lens_constants,
    mix_logs,
    plane_constants,
    plane_pixel,
    plane_pixels,
    plane_point,
    project_lens,
)
from photomodel.fitness._protocols import kernel_values

_OFFSET_ITERATIONS = 3
"""Mean-shift steps of the light offsets from each start."""

_OPPONENT = np.array([[1 / 3, 1 / 3, 1 / 3], [0.0, -1.0, 1.0], [-1.0, 0.5, 0.5]])
_LOGS = np.linalg.inv(_OPPONENT)
"""(l, a, b) = _OPPONENT @ (ln B', ln G', ln R') and back (X' = X + 8, as in log_opponent)."""


@njit(inline="always", fastmath=True, error_model="numpy")
def _bilinear_cell(img, u, v):  # pragma: no cover - compiled
    """The top-left pixel (iu, iv) of the 2 x 2 cell that interpolates ``img`` at (u, v),
    and the fractions (fu, fv) across it; iu = -1 where (u, v) lies outside the image."""
    h = img.shape[0]
    w = img.shape[1]
    if not (u >= 0.0 and v >= 0.0 and u <= w - 1.0 and v <= h - 1.0):
        return -1, -1, 0.0, 0.0
    iu = min(int(u), w - 2)
    iv = min(int(v), h - 2)
    return iu, iv, u - iu, v - iv


@njit(inline="always", fastmath=True, error_model="numpy")
def _bilinear(img, u, v, out):  # pragma: no cover - compiled
    """``out`` (3,) = the bilinear sample of ``img`` at (u, v); False outside the image."""
    iu, iv, fu, fv = _bilinear_cell(img, u, v)
    if iu < 0:
        return False
    for c in range(3):
        top = img[iv, iu, c] * (1.0 - fu) + img[iv, iu + 1, c] * fu
        bottom = img[iv + 1, iu, c] * (1.0 - fu) + img[iv + 1, iu + 1, c] * fu
        out[c] = top * (1.0 - fv) + bottom * fv
    return True


@njit(inline="always", fastmath=True, error_model="numpy")
def _sample_point(R, t, K, D, x, y, img, out):  # pragma: no cover - compiled
    """``out`` = the bilinear sample of ``img`` where the model-plane point ``(x, y)`` lies at
    pose ``(R, t)`` through camera ``K``, ``D``; False when it falls outside the image."""
    u, v = plane_pixel(R, t, K, D, x, y)
    return _bilinear(img, u, v, out)


@njit(inline="always", fastmath=True, error_model="numpy")
def _light_gain(o, gain):  # pragma: no cover - compiled
    """``gain`` = the factors of the light offsets ``o`` on the linear channels (B', G', R'):
    exp of the offsets' log channels."""
    for k in range(3):
        gain[k] = np.exp(_LOGS[k, 0] * o[0] + _LOGS[k, 1] * o[1] + _LOGS[k, 2] * o[2])


@njit(inline="always", fastmath=True, error_model="numpy")
def _distance2(dl, da, db, o, inv_var_l, inv_var_c):  # pragma: no cover - compiled
    """Squared colour distance of a feature difference (dl, da, db) after the offsets."""
    el = dl - o[0]
    ea = da - o[1]
    eb = db - o[2]
    return el * el * inv_var_l + (ea * ea + eb * eb) * inv_var_c


@njit(inline="always", fastmath=True, error_model="numpy")
def _offset_agreement(dl, da, db, ol, oa, ob, inv_var_l, inv_var_c):  # pragma: no cover
    """Agreement of a feature difference (dl, da, db) after the offsets (ol, oa, ob), given
    as scalars: a loop over samples of it vectorises."""
    el = dl - ol
    ea = da - oa
    eb = db - ob
    return exp_neg(0.5 * (el * el * inv_var_l + (ea * ea + eb * eb) * inv_var_c))


@njit(inline="always", fastmath=True, error_model="numpy")
def _agreement(sample, colour, o, inv_var_l, inv_var_c):  # pragma: no cover - compiled
    return exp_neg(0.5 * _distance2(sample[0] - colour[0], sample[1] - colour[1],
                                    sample[2] - colour[2], o, inv_var_l, inv_var_c))


@njit(inline="always", fastmath=True, error_model="numpy")
def _best_agreement(sample, palette, o, inv_var_l, inv_var_c):  # pragma: no cover - compiled
    """Agreement with the nearest palette colour: one exp of the smallest distance."""
    best = np.inf
    for k in range(palette.shape[0]):
        best = min(best, _distance2(sample[0] - palette[k, 0], sample[1] - palette[k, 1],
                                    sample[2] - palette[k, 2], o, inv_var_l, inv_var_c))
    return exp_neg(0.5 * best)


@njit(inline="always", error_model="numpy")
def ring_size(table_out):  # pragma: no cover - compiled
    """Inner points up to the last one with a band point in ``table_out`` (the inner ring
    comes first, the interior after it): the ones :func:`ring_mixtures` covers."""
    n = table_out.shape[0]
    while n > 0 and table_out[n - 1] < 0:
        n -= 1
    return n


@njit(inline="always", error_model="numpy")
def _mix_inputs(work, i, k, own, table, seen):  # pragma: no cover - compiled
    """Entry ``i`` of :func:`mix_logs`' inputs: ``own`` (the model's part of log channel
    ``k``'s intensity) and the table colour ``table``'s log channel ``k`` where the table is
    ``seen``; else 1 and 0, an entry whose result goes unused."""
    if seen:
        work[0, i] = own
        work[1, i] = _LOGS[k, 0] * table[0] + _LOGS[k, 1] * table[1] + _LOGS[k, 2] * table[2]
    else:
        work[0, i] = 1.0
        work[1, i] = 0.0


@njit(error_model="numpy")
def ring_mixtures(lin_in, gain, table_out, band, band_ok, t, work):  # pragma: no cover
    """The edge mixture of each of the ``n = work.shape[1] // 3`` first inner points with a
    band point ``table_out[j] >= 0`` whose sample ``band`` (N_out, 3) is ``band_ok``: its
    model colour mixed with the fraction ``t`` of the scene's table colour seen at that band
    point, in linear intensity (as the optics and the pixel mix them), not in the logarithms.
    ``work[3, k n + j]`` = log channel ``k`` (B', G', R') of point ``j``'s expected colour
    and ``work[2, k n + j]`` the table's part of its intensity (:func:`mix_logs`; the
    others' entries are of no use). The model colour is given linear, ``lin_in`` = exp of
    its log channels, and takes the scene's offsets as the factors ``gain`` = exp of the
    offsets' log channels (intensities + LOG_OFFSET mix as intensities do: the offset
    carries through). Laid out by channel so that the exponentials and logarithms run in
    one loop that vectorises."""
    n = work.shape[1] // 3
    for k in range(3):
        for j in range(n):
            b = table_out[j]
            _mix_inputs(work, k * n + j, k, (1.0 - t) * lin_in[j, k] * gain[k], band[b],
                        b >= 0 and band_ok[b])
    mix_logs(t, work)


@njit(error_model="numpy")
def slide_mixtures(lin, gain, tables, tables_ok, t, work):  # pragma: no cover - compiled
    """:func:`ring_mixtures` of one inner point, its linear model colour ``lin`` (3,), with
    each of the ``n = work.shape[1] // 3`` table colours ``tables`` (n, 3) that is
    ``tables_ok`` (its band point's samples at the score's slides)."""
    n = work.shape[1] // 3
    for k in range(3):
        own = (1.0 - t) * lin[k] * gain[k]
        for q in range(n):
            _mix_inputs(work, k * n + q, k, own, tables[q], tables_ok[q])
    mix_logs(t, work)


@njit(inline="always", fastmath=True, error_model="numpy")
def mixed_features(work, j, out):  # pragma: no cover - compiled
    """``out`` = the features (l, a, b) of ring point ``j``'s edge mixture in ``work``
    (:func:`ring_mixtures`)."""
    for c in range(3):
        out[c] = _mixed_feature(work, j, c)


@njit(inline="always", fastmath=True, error_model="numpy")
def _mixed_feature(work, j, c):  # pragma: no cover - compiled
    """Feature ``c`` (0: l, 1: a, 2: b) of :func:`mixed_features`, as a scalar (a loop over
    ring points or slides of it vectorises)."""
    n = work.shape[1] // 3
    return (_OPPONENT[c, 0] * work[3, j] + _OPPONENT[c, 1] * work[3, n + j]
            + _OPPONENT[c, 2] * work[3, 2 * n + j])


@njit(fastmath=True, error_model="numpy")
def _camera_samples(R, t, K, D, xy_in, xy_out, img, buf, valid, band, band_ok,
                    pix):  # pragma: no cover - compiled
    """One camera's samples of the model points at pose ``(R, t)``: ``buf`` (N_in, 3) the
    inner points', ``valid`` (N_in,) whether each fell inside the image (1.0 or 0.0),
    ``band`` (N_out, 3) and ``band_ok`` (N_out,) the band's; ``pix`` (2, max(N_in, N_out))
    is work space (the points' pixels). What :func:`_camera_terms` compares with the
    model's colours, which several colourings of the same points share. A point outside
    the image keeps the last sample (finite: the comparisons pass over every point and
    weigh it by ``valid`` or ``band_ok``)."""
    sample = np.zeros(3)
    plane_pixels(R, t, K, D, xy_out, pix)
    for j in range(xy_out.shape[1]):
        band_ok[j] = _bilinear(img, pix[0, j], pix[1, j], sample)
        for c in range(3):
            band[j, c] = sample[c]
    plane_pixels(R, t, K, D, xy_in, pix)
    for j in range(xy_in.shape[1]):
        valid[j] = 1.0 if _bilinear(img, pix[0, j], pix[1, j], sample) else 0.0
        for c in range(3):
            buf[j, c] = sample[c]


@njit(fastmath=True, error_model="numpy")
def _camera_terms(f_in, f_out, palette, palette_weight, inv_var_l, inv_var_c, wb_weight,
                  table_out, mix_t, lin_in, buf, diff, valid, band, band_ok, mix_work,
                  out):  # pragma: no cover - compiled
    """out[:] = (F_c, mean S_in agreement, mean S_out agreement, o_l, o_a, o_b) of one
    camera's samples (:func:`_camera_samples`: ``buf``, ``valid``, ``band``, ``band_ok``)
    against the model colours ``f_in`` (N_in, 3) and ``f_out`` (N_out, 3).

    With a non-empty ``palette`` (K, 3) a sample agrees at least ``palette_weight`` times
    as well as its best palette colour (garment anywhere), not only as well as its own
    point's colour (this part of the garment). With ``mix_t`` > 0 an inner-ring point with
    a band point ``table_out[j] >= 0`` is expected to show its model colour mixed with that
    fraction of the table colour seen at the band point (the blurred edge), once the offsets
    are known; ``lin_in`` (N_in, 3) holds the model colours linear (exp of the log channels
    B', G', R'). ``diff`` (3, N_in) is work space: the samples' differences to the model's
    colours by channel; ``mix_work`` (4, 3 ring_size(table_out)) the edge mixtures'
    (:func:`ring_mixtures`).
    """
    use_palette = palette.shape[0] > 0
    n_in = f_in.shape[0]
    o = np.zeros(3)
    n_valid = 0.0
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    for j in range(n_in):    # without branches, so that it vectorises
        inside = valid[j] > 0.0
        # zero differences outside the image: the passes below weigh them by valid = 0
        d0 = buf[j, 0] - f_in[j, 0] if inside else 0.0
        d1 = buf[j, 1] - f_in[j, 1] if inside else 0.0
        d2 = buf[j, 2] - f_in[j, 2] if inside else 0.0
        diff[0, j] = d0
        diff[1, j] = d1
        diff[2, j] = d2
        s0 += d0
        s1 += d1
        s2 += d2
        n_valid += valid[j]
    o[0] = s0
    o[1] = s1
    o[2] = s2
    if n_valid == 0.0:
        for k in range(6):
            out[k] = 0.0
        return
    for c in range(3):
        o[c] /= n_valid
    # The offsets maximise mean agreement - chroma penalty (a mode, not the mean): occluders
    # and shadows disagree with the model and must not drag them. Fixed-point (mean-shift)
    # ascent from the mean and from no offset; the better end point is kept. The inner
    # points' agreement sum at the kept offsets is S_in (without a palette). The passes run
    # over the differences laid out by channel, without branches: they vectorise.
    ridge = 2.0 * wb_weight * n_in / inv_var_c
    dl = diff[0]    # one array per channel: unit strides the compiler can see
    da = diff[1]
    db = diff[2]
    best_j = -1e300
    best_sum = 0.0
    best_o = np.zeros(3)
    for start in range(2):
        t0 = o[0] if start == 0 else 0.0
        t1 = o[1] if start == 0 else 0.0
        t2 = o[2] if start == 0 else 0.0
        for _ in range(_OFFSET_ITERATIONS):
            sw = 0.0
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            for j in range(n_in):
                a = valid[j] * _offset_agreement(dl[j], da[j], db[j], t0, t1, t2, inv_var_l,
                                                 inv_var_c)
                sw += a
                s0 += a * dl[j]
                s1 += a * da[j]
                s2 += a * db[j]
            if sw < 1e-9:
                break
            t0 = s0 / sw
            t1 = s1 / (sw + ridge)
            t2 = s2 / (sw + ridge)
        total = 0.0
        for j in range(n_in):
            total += valid[j] * _offset_agreement(dl[j], da[j], db[j], t0, t1, t2, inv_var_l,
                                                  inv_var_c)
        j_val = total / n_in - wb_weight * (t1 * t1 + t2 * t2)
        if j_val > best_j:
            best_j = j_val
            best_sum = total
            best_o[0] = t0
            best_o[1] = t1
            best_o[2] = t2
    for c in range(3):
        o[c] = best_o[c]
    s_in = best_sum
    if mix_t > 0.0:
        expected = np.empty(3)
        gain = np.empty(3)
        _light_gain(o, gain)
        ring_mixtures(lin_in, gain, table_out, band, band_ok, mix_t, mix_work)
        ring = mix_work.shape[1] // 3
        o0, o1, o2 = o[0], o[1], o[2]
        # A ring point whose band point is seen trades its plain agreement for the mixture's:
        # one pass without branches (both agreements of every ring point, the trade kept
        # where it applies), which vectorises.
        for j in range(ring):
            k = table_out[j]
            mixed = (valid[j] > 0.0) & (k >= 0) & band_ok[max(k, 0)]
            plain = _offset_agreement(diff[0, j], diff[1, j], diff[2, j], o0, o1, o2,
                                      inv_var_l, inv_var_c)
            mix = _offset_agreement(buf[j, 0] - _mixed_feature(mix_work, j, 0) + o0,
                                    buf[j, 1] - _mixed_feature(mix_work, j, 1) + o1,
                                    buf[j, 2] - _mixed_feature(mix_work, j, 2) + o2,
                                    o0, o1, o2, inv_var_l, inv_var_c)
            s_in += mix - plain if mixed else 0.0
        if use_palette:    # the palette compares the mixture's differences too
            for j in range(ring):
                k = table_out[j]
                if valid[j] > 0.0 and k >= 0 and band_ok[k]:
                    mixed_features(mix_work, j, expected)
                    for c in range(3):   # so that diff - o = sample - expected
                        diff[c, j] = buf[j, c] - expected[c] + o[c]
    if use_palette:
        s_in = 0.0
        for j in range(n_in):
            if valid[j] > 0.0:
                a = exp_neg(0.5 * _distance2(diff[0, j], diff[1, j], diff[2, j], o,
                                             inv_var_l, inv_var_c))
                s_in += max(a, palette_weight * _best_agreement(buf[j], palette, o, inv_var_l,
                                                                inv_var_c))
    s_out = 0.0
    if use_palette:
        for j in range(f_out.shape[0]):
            if band_ok[j]:
                a = _agreement(band[j], f_out[j], o, inv_var_l, inv_var_c)
                s_out += max(a, palette_weight * _best_agreement(band[j], palette, o,
                                                                 inv_var_l, inv_var_c))
            else:
                s_out += 1.0
    else:    # one pass without branches, which vectorises
        o0, o1, o2 = o[0], o[1], o[2]
        for j in range(f_out.shape[0]):
            a = _offset_agreement(band[j, 0] - f_out[j, 0], band[j, 1] - f_out[j, 1],
                                  band[j, 2] - f_out[j, 2], o0, o1, o2, inv_var_l, inv_var_c)
            # no contrast seen where the band leaves the image: as bad as garment there
            s_out += a if band_ok[j] else 1.0
    s_in /= n_in
    if f_out.shape[0] > 0:
        s_out /= f_out.shape[0]
    out[0] = s_in - s_out - wb_weight * (o[1] * o[1] + o[2] * o[2])
    out[1] = s_in
    out[2] = s_out
    out[3] = o[0]
    out[4] = o[1]
    out[5] = o[2]


@njit(inline="always", fastmath=True, error_model="numpy")
def _pair_camera(q, Rs, ts, R21, T21, K1, D1, K2, D2, img1, img2):  # pragma: no cover
    """Pose, intrinsics, distortion and image of (pose, camera) pair ``q``: pose ``q // 2``
    seen by camera 1 (even ``q``) or camera 2 (odd)."""
    p = q // 2
    if q % 2 == 0:
        return Rs[p], ts[p], K1, D1, img1
    R, t = camera2_pose(Rs[p], ts[p], R21, T21)
    return R, t, K2, D2, img2


@njit(fastmath=True, error_model="numpy")
def _fitness_lane(lane, lanes, Rs, ts, R21, T21, K1, D1, K2, D2, xy_in, f_in, xy_out, f_out,
                  palette, palette_weight, img1, img2, inv_var_l, inv_var_c, wb_weight,
                  table_out, mix_t, lin_in, out_terms):  # pragma: no cover - compiled
    """Thread ``lane``'s part of :func:`soft_fitness_terms`: every ``lanes``-th (pose,
    camera) pair from ``lane``, with its own work space."""
    n_in = xy_in.shape[1]
    pairs = 2 * Rs.shape[0]
    buf = np.empty((n_in, 3))
    diff = np.empty((3, n_in))
    valid = np.empty(n_in)
    band = np.empty((xy_out.shape[1], 3))
    band_ok = np.empty(xy_out.shape[1], dtype=np.bool_)
    pix = np.empty((2, max(n_in, xy_out.shape[1])))
    mix_work = np.empty((4, 3 * ring_size(table_out)))
    for q in range(lane, pairs, lanes):
        p = q // 2
        R, t, K, D, img = _pair_camera(q, Rs, ts, R21, T21, K1, D1, K2, D2, img1, img2)
        _camera_samples(R, t, K, D, xy_in, xy_out, img, buf, valid, band, band_ok, pix)
        _camera_terms(f_in, f_out, palette, palette_weight, inv_var_l, inv_var_c,
                      wb_weight, table_out, mix_t, lin_in, buf, diff, valid, band,
                      band_ok, mix_work, out_terms[p, q % 2])


@njit(parallel=True, fastmath=True, error_model="numpy")
def soft_fitness_terms(T, lanes, args):  # pragma: no cover - compiled
    """The fitness (P,) and each camera's terms (P, 2, 6: F_c, S_in agreement, S_out
    agreement, offsets l, a, b) of the maps ``T`` (P, 4, 4) of model points into camera 1
    (their first two columns, and the translation), on ``lanes`` threads (the number of
    threads; each takes every ``lanes``-th (pose, camera) pair with its own work space: a
    single pose's two cameras run side by side). ``args`` holds
    the kernel's fixed arguments (``SoftFitness.kernel_args``): ``R21``, ``T21``, ``K1``,
    ``D1``, ``K2``, ``D2``, ``xy_in`` (2, N_in) and ``xy_out`` (2, N_out) the model points'
    x and y by row, ``f_in``, ``f_out``, ``palette``, ``palette_weight``, ``img1``,
    ``img2``, ``inv_var_l``, ``inv_var_c``, ``wb_weight``, ``table_out``, ``mix_t``,
    ``lin_in``. Called from Python and from the searches' numba loops alike
    (``numba.get_num_threads()`` inside would keep it from the cache)."""
    (R21, T21, K1, D1, K2, D2, xy_in, f_in, xy_out, f_out, palette, palette_weight, img1,
     img2, inv_var_l, inv_var_c, wb_weight, table_out, mix_t, lin_in) = args
    P = T.shape[0]
    Rs, ts = _pose_rows(T)
    out_f = np.empty(P)
    out_terms = np.empty((P, 2, 6))
    pairs = 2 * P    # (pose, camera) pairs: a single pose keeps two threads busy
    lanes = min(lanes, pairs)
    for lane in prange(lanes):     # work space once per thread
        _fitness_lane(np.int64(lane), lanes, Rs, ts, R21, T21, K1, D1, K2, D2, xy_in, f_in,
                      xy_out, f_out, palette, palette_weight, img1, img2, inv_var_l, inv_var_c,
                      wb_weight, table_out, mix_t, lin_in, out_terms)
    for p in range(P):
        out_f[p] = 0.5 * (out_terms[p, 0, 0] + out_terms[p, 1, 0])
    return out_f, out_terms


@njit(parallel=True, fastmath=True, error_model="numpy")
def soft_colourings_terms(T, args, f_ins, f_outs, mix_ts, lin_ins):  # pragma: no cover
    """Each camera's terms (S, 2, 6) (as :func:`soft_fitness_terms`', without a palette) at
    the map ``T`` (1, 4, 4) for S colourings of the same points: ``f_ins`` (S, N_in, 3),
    ``f_outs`` (S, N_out, 3), ``mix_ts`` (S,), ``lin_ins`` (S, N_in, 3) (the model under S
    camera blurs), with the fixed arguments of one of the colourings'
    ``SoftFitness.kernel_args`` (``args``). Each camera samples its image once, on its own
    thread; the colourings compare those samples in turn."""
    (R21, T21, K1, D1, K2, D2, xy_in, _f_in, xy_out, _f_out, _palette, _weight, img1, img2,
     inv_var_l, inv_var_c, wb_weight, table_out, _mix_t, _lin_in) = args
    Rs, ts = _pose_rows(T)
    out_terms = np.empty((f_ins.shape[0], 2, 6))
    for cam in prange(2):
        _colourings_camera(np.int64(cam), Rs, ts, R21, T21, K1, D1, K2, D2, xy_in, xy_out, f_ins,
                           f_outs, img1, img2, inv_var_l, inv_var_c, wb_weight, table_out,
                           mix_ts, lin_ins, out_terms)
    return out_terms


@njit(fastmath=True, error_model="numpy")
def _colourings_camera(cam, Rs, ts, R21, T21, K1, D1, K2, D2, xy_in, xy_out, f_ins, f_outs,
                       img1, img2, inv_var_l, inv_var_c, wb_weight, table_out, mix_ts, lin_ins,
                       out_terms):  # pragma: no cover - compiled
    """Camera ``cam``'s part of :func:`soft_colourings_terms`: ``out_terms[:, cam]``."""
    n_in = xy_in.shape[1]
    n_out = xy_out.shape[1]
    palette = np.zeros((0, 3))
    buf = np.empty((n_in, 3))
    diff = np.empty((3, n_in))
    valid = np.empty(n_in)
    band = np.empty((n_out, 3))
    band_ok = np.empty(n_out, dtype=np.bool_)
    pix = np.empty((2, max(n_in, n_out)))
    mix_work = np.empty((4, 3 * ring_size(table_out)))
    R, t, K, D, img = _pair_camera(cam, Rs, ts, R21, T21, K1, D1, K2, D2, img1, img2)
    _camera_samples(R, t, K, D, xy_in, xy_out, img, buf, valid, band, band_ok, pix)
    for k in range(f_ins.shape[0]):
        _camera_terms(f_ins[k], f_outs[k], palette, 0.0, inv_var_l, inv_var_c, wb_weight,
                      table_out, mix_ts[k], lin_ins[k], buf, diff, valid, band, band_ok,
                      mix_work, out_terms[k, cam])


@njit(error_model="numpy")
def _pose_rows(T):  # pragma: no cover - compiled
    """The rotations (P, 3, 3) (the maps' first three columns) and translations (P, 3) of
    the maps ``T`` (P, 4, 4), as the kernels take them."""
    P = T.shape[0]
    Rs = np.empty((P, 3, 3))
    ts = np.empty((P, 3))
    for p in range(P):
        for i in range(3):
            ts[p, i] = T[p, i, 3]
            for j in range(3):
                Rs[p, i, j] = T[p, i, j]
    return Rs, ts


@njit(error_model="numpy")
def soft_fitness_values(T, lanes, args):  # pragma: no cover - compiled
    """The fitness (P,) of :func:`soft_fitness_terms` and each pose's light offsets (P, 2,
    3): the pose kernel the searches' numba loops call (``SoftFitness.kernel_args``), its
    body compiled into them as ``kernel_values``' implementation."""
    f, terms = soft_fitness_terms(T, lanes, args)
    return f, terms[:, :, 3:6]


def soft_args_type(args: types.Type, size: int, images: tuple[int, int]) -> bool:
    """Whether the numba type ``args`` is the tuple of ``size`` arguments of a ``soft``
    kernel, its float32 images at ``images``."""
    return (isinstance(args, types.BaseTuple) and len(args) == size
            and all(isinstance(args[i], types.Array) and args[i].dtype == types.float32
                    and args[i].ndim == 3 for i in images))


@overload(kernel_values)
def _kernel_values(T, lanes, args):  # type: ignore[no-untyped-def]
    """The ``soft`` fitness's implementation of the searches' ``kernel_values``: the body of
    :func:`soft_fitness_values` (not a call of it, which would be one more compiled layer)."""
    if soft_args_type(args, 20, (12, 13)):
        return soft_fitness_values.py_func
    return None


@njit(fastmath=True, error_model="numpy")
def _camera_residuals(R, t, K, D, p_in, f_in, p_out, f_out, img, scale_l, scale_c, table_out,
                      mix_t, lin_in, o, band, mix_work, out_r, out_ok):  # pragma: no cover
    """Residuals of one camera at fixed light offsets ``o``: ``out_r`` (N_in + N_out, 3)
    the scaled colour differences (inner points first, then the band), ``out_ok`` whether
    each sample fell inside the image. ``band`` (N_out, 3) and ``mix_work`` (4, 3
    ring_size(table_out)) are work space."""
    n_in = p_in.shape[0]
    sample = np.empty(3)
    expected = np.empty(3)
    gain = np.empty(3)
    _light_gain(o, gain)
    for j in range(p_out.shape[0]):
        ok = _sample_point(R, t, K, D, p_out[j, 0], p_out[j, 1], img, sample)
        out_ok[n_in + j] = ok
        for c in range(3):
            band[j, c] = sample[c]
        out_r[n_in + j, 0] = (sample[0] - f_out[j, 0] - o[0]) * scale_l
        out_r[n_in + j, 1] = (sample[1] - f_out[j, 1] - o[1]) * scale_c
        out_r[n_in + j, 2] = (sample[2] - f_out[j, 2] - o[2]) * scale_c
    if mix_t > 0.0:
        ring_mixtures(lin_in, gain, table_out, band, out_ok[n_in:], mix_t, mix_work)
    for j in range(n_in):
        ok = _sample_point(R, t, K, D, p_in[j, 0], p_in[j, 1], img, sample)
        out_ok[j] = ok
        k = table_out[j]
        if ok and mix_t > 0.0 and k >= 0 and out_ok[n_in + k]:
            mixed_features(mix_work, j, expected)
            for c in range(3):
                expected[c] = sample[c] - expected[c]
        else:
            for c in range(3):
                expected[c] = sample[c] - f_in[j, c] - o[c]
        out_r[j, 0] = expected[0] * scale_l
        out_r[j, 1] = expected[1] * scale_c
        out_r[j, 2] = expected[2] * scale_c


@njit(parallel=True, fastmath=True, error_model="numpy")
def soft_residuals_kernel(Rs, ts, R21, T21, K1, D1, K2, D2, p_in, f_in, p_out, f_out, img1,
                          img2, scale_l, scale_c, table_out, mix_t, lin_in, offsets, lanes,
                          out_r, out_ok):  # pragma: no cover - compiled
    """Fill ``out_r`` (P, 2, N_in + N_out, 3) with both cameras' scaled colour residuals at
    the fixed light offsets ``offsets`` (2, 3), and ``out_ok`` (P, 2, N_in + N_out) with
    whether each sample fell inside its image; (pose, camera) pairs on ``lanes`` threads as
    in :func:`soft_fitness_terms`."""
    pairs = 2 * Rs.shape[0]    # (pose, camera) pairs
    lanes = min(lanes, pairs)
    for lane in prange(lanes):
        band = np.empty((p_out.shape[0], 3))
        mix_work = np.empty((4, 3 * ring_size(table_out)))
        for q in range(lane, pairs, lanes):
            p = q // 2
            R, t, K, D, img = _pair_camera(q, Rs, ts, R21, T21, K1, D1, K2, D2, img1, img2)
            _camera_residuals(R, t, K, D, p_in, f_in, p_out, f_out, img, scale_l, scale_c,
                              table_out, mix_t, lin_in, offsets[q % 2], band, mix_work,
                              out_r[p, q % 2], out_ok[p, q % 2])


@njit(inline="always", error_model="numpy")
def _plane_affine(plane, lens, x, y):  # pragma: no cover - compiled
    """Pixel (u, v) of the model-plane point ``(x, y)`` and the pixel steps of 1 mm along the
    model's x and y there (forward differences): (u, v, du_x, dv_x, du_y, dv_y); the pose and
    camera as :func:`~photomodel.fitness._kernels.plane_constants` and ``lens_constants``."""
    X, Y, Z = plane_point(plane, x, y)
    u, v = project_lens(X, Y, Z, lens)
    X, Y, Z = plane_point(plane, x + 1.0, y)
    ux, vx = project_lens(X, Y, Z, lens)
    X, Y, Z = plane_point(plane, x, y + 1.0)
    uy, vy = project_lens(X, Y, Z, lens)
    return u, v, ux - u, vx - v, uy - u, vy - v


@njit(inline="always", error_model="numpy")
def _plane_affines(R, t, K, D, xy, out):  # pragma: no cover - compiled
    """``out`` (6, N) = :func:`_plane_affine` of each model-plane point ``xy`` (2, N: x and y
    by row), in one loop that vectorises; the pose's and camera's constants are read once
    before it."""
    plane = plane_constants(R, t)
    lens = lens_constants(K, D)
    for j in range(xy.shape[1]):
        (out[0, j], out[1, j], out[2, j], out[3, j], out[4, j],
         out[5, j]) = _plane_affine(plane, lens, xy[0, j], xy[1, j])


@njit(inline="always", fastmath=True, error_model="numpy")
def _slide_samples(img, u0, v0, du_x, dv_x, du_y, dv_y, shifts, smp,
                   inside):  # pragma: no cover - compiled
    """``smp`` (3, S) = the bilinear samples of ``img`` at pixel (u0, v0) moved by each of
    the ``shifts`` (S, 2) mm along the model's x and y (pixel steps ``du_x, dv_x`` and
    ``du_y, dv_y`` a mm), by channel; ``inside`` (S,) 1.0 where inside the image, else 0.0
    (and that slide's samples unchanged)."""
    sample = np.empty(3)
    for q in range(shifts.shape[0]):
        u = u0 + du_x * shifts[q, 0] + du_y * shifts[q, 1]
        v = v0 + dv_x * shifts[q, 0] + dv_y * shifts[q, 1]
        if _bilinear(img, u, v, sample):
            inside[q] = 1.0
            for k in range(3):
                smp[k, q] = sample[k]
        else:
            inside[q] = 0.0


@njit(fastmath=True, error_model="numpy")
def _slack_camera(M, t, K, D, img, o, shifts, xy_in, f_in, xy_out, f_out, inv_var_l,
                  inv_var_c, table_out, mix_t, lin_in, pair_out, cell_in, cell_out,
                  out):  # pragma: no cover - compiled
    """One camera's part of :func:`soft_slack_sums_kernel`: ``out`` (S, 3, C)."""
    n_in = xy_in.shape[1]
    n_out = xy_out.shape[1]
    S = shifts.shape[0]
    cells = out.shape[2]
    gain = np.empty(3)
    _light_gain(o, gain)
    # A point's slides side by side (the inner ring reads its band point's 25 at once),
    # and the sums by cell: (cell, term, slide).
    band = np.empty((n_out, S, 3))
    band_a = np.empty((n_out, S))
    band_ok = np.empty((n_out, S), dtype=np.bool_)
    sums = np.zeros((cells, 3, S))
    # A point's slides by channel (l, a, b rows) and whether each fell inside (1.0 or
    # 0.0): the samples one slide at a time, everything after them as passes over the
    # slides that vectorise.
    smp = np.zeros((3, S))
    inside = np.empty(S)
    a = np.empty(S)
    mix_work = np.empty((4, 3 * S))
    aff = np.empty((6, max(n_in, n_out)))    # each point's pixel and steps a mm
    _plane_affines(M, t, K, D, xy_out, aff)
    for j in range(n_out):
        _slide_samples(img, aff[0, j], aff[1, j], aff[2, j], aff[3, j], aff[4, j],
                       aff[5, j], shifts, smp, inside)
        c = cell_out[j]
        for q in range(S):
            band_ok[j, q] = inside[q] > 0.0
            for k in range(3):
                band[j, q, k] = smp[k, q]
        f0 = f_out[j, 0] + o[0]
        f1 = f_out[j, 1] + o[1]
        f2 = f_out[j, 2] + o[2]
        for q in range(S):
            a[q] = _offset_agreement(smp[0, q], smp[1, q], smp[2, q], f0, f1, f2, inv_var_l,
                                     inv_var_c) if inside[q] > 0.0 else 1.0
        for q in range(S):
            band_a[j, q] = a[q]
            sums[c, 1, q] += a[q]
    mixed = np.empty(S)
    _plane_affines(M, t, K, D, xy_in, aff)
    for j in range(n_in):
        _slide_samples(img, aff[0, j], aff[1, j], aff[2, j], aff[3, j], aff[4, j],
                       aff[5, j], shifts, smp, inside)
        c = cell_in[j]
        mix = table_out[j]
        pair = pair_out[j]
        f0 = f_in[j, 0] + o[0]
        f1 = f_in[j, 1] + o[1]
        f2 = f_in[j, 2] + o[2]
        if mix_t > 0.0 and mix >= 0:
            slide_mixtures(lin_in[j], gain, band[mix], band_ok[mix], mix_t, mix_work)
            for q in range(S):
                mixed[q] = 1.0 if band_ok[mix, q] else 0.0
            for q in range(S):   # the edge mixture's features where its table is seen
                m0 = _mixed_feature(mix_work, q, 0)
                m1 = _mixed_feature(mix_work, q, 1)
                m2 = _mixed_feature(mix_work, q, 2)
                mx = mixed[q] > 0.0
                a[q] = inside[q] * _offset_agreement(
                    smp[0, q], smp[1, q], smp[2, q], m0 if mx else f0, m1 if mx else f1,
                    m2 if mx else f2, inv_var_l, inv_var_c)
        else:
            for q in range(S):
                a[q] = inside[q] * _offset_agreement(smp[0, q], smp[1, q], smp[2, q], f0, f1,
                                                     f2, inv_var_l, inv_var_c)
        for q in range(S):
            sums[c, 0, q] += a[q]
        if pair >= 0:
            for q in range(S):
                if band_ok[pair, q]:
                    sums[c, 2, q] += a[q] * (1.0 - band_a[pair, q])
    for q in range(S):
        for term in range(3):
            for c in range(cells):
                out[q, term, c] = sums[c, term, q]


@njit(parallel=True, fastmath=True, error_model="numpy")
def soft_slack_sums_kernel(Ms, ts, K1, D1, K2, D2, shifts, xy_in, f_in, xy_out, f_out, img1,
                           img2, inv_var_l, inv_var_c, table_out, mix_t, lin_in, offsets,
                           pair_out, cell_in, cell_out, out):  # pragma: no cover - compiled
    """Fill ``out`` (S, 2, 3, C) with each (slide, camera, cell)'s sums of the inner points'
    agreement (inside the image, else 0), of the band points' agreement (inside, else 1)
    and of the outline pairs' ``a_in (1 - a_out)`` (both inside, else 0), at the fixed light
    offsets ``offsets`` (2, 3), with every point slid by ``shifts`` (S, 2) mm in the model
    plane. ``Ms`` (2, 3, 3) and ``ts`` (2, 3) map model points into each camera, ``xy_in``
    (2, N_in) and ``xy_out`` (2, N_out) are their x and y by row;
    ``pair_out`` (N_in,) is each inner point's band point in an outline pair (-1: none),
    ``cell_in`` (N_in,) and ``cell_out`` (N_out,) each point's cell (a pair counts in its
    inner point's). Colours compared as in :func:`soft_fitness_terms`; a point's pixel
    moves with a slide by the projection's forward differences over 1 mm (exact at no
    slide, within about 0.002 px at 1 mm), and its slides are sampled together, where the
    image is in cache; the work arrays keep a point's slides side by side and the sums by
    cell (the inner ring reads its band point's 25 slides at once, side by side in
    memory). The two cameras run on two threads."""
    for cam in prange(2):
        _slack_camera(Ms[cam], ts[cam], K1 if cam == 0 else K2, D1 if cam == 0 else D2,
                      img1 if cam == 0 else img2, offsets[cam], shifts, xy_in, f_in, xy_out,
                      f_out, inv_var_l, inv_var_c, table_out, mix_t, lin_in, pair_out, cell_in,
                      cell_out, out[:, cam])
