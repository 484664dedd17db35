"""The paper's pose vector (x, y, z, eps1, eps2, eps3) and conversions.

``eps`` is the vector part of a unit quaternion whose scalar part ``w`` is taken non-negative,
``w = sqrt(1 - |eps|^2)``, so every rotation of angle below 180 deg has exactly one ``eps``.
Quaternions elsewhere are ``quat_wxyz``; scipy's ``Rotation`` (which uses x, y, z, w order
internally) does the conversions.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from photomodel._jit import njit


def rotation_from_eps(eps: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrices (..., 3, 3) from quaternion vector parts ``eps`` (..., 3), |eps| <= 1.

    Computed in closed form by a numba kernel (no scipy call): it runs on whole GA
    populations, about a thousand times a search.
    """
    e = np.asarray(eps, dtype=np.float64)
    R = _rotations(np.ascontiguousarray(e.reshape(-1, 3)), 0)
    return R.reshape(e.shape[:-1] + (3, 3))


@njit
def _rotations(e: NDArray[np.float64], first: int) -> NDArray[np.float64]:  # pragma: no cover
    """Rotation matrices (N, 3, 3) of the quaternion vector parts in columns ``first`` to
    ``first + 2`` of ``e`` (N, K): one compiled specialisation for Python's calls and
    :func:`_maps`' alike."""
    R = np.empty((e.shape[0], 3, 3))
    for i in range(e.shape[0]):
        x, y, z = e[i, first], e[i, first + 1], e[i, first + 2]
        w = math.sqrt(max(1.0 - (x * x + y * y + z * z), 0.0))
        R[i, 0, 0] = 1 - 2 * (y * y + z * z)
        R[i, 0, 1] = 2 * (x * y - z * w)
        R[i, 0, 2] = 2 * (x * z + y * w)
        R[i, 1, 0] = 2 * (x * y + z * w)
        R[i, 1, 1] = 1 - 2 * (x * x + z * z)
        R[i, 1, 2] = 2 * (y * z - x * w)
        R[i, 2, 0] = 2 * (x * z - y * w)
        R[i, 2, 1] = 2 * (y * z + x * w)
        R[i, 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def pose_vectors_to_matrices(poses: ArrayLike) -> NDArray[np.float64]:
    """Transforms ``T_cam1_model`` (N, 4, 4) from pose vectors (N, 6) = (x, y, z, eps1..3), mm."""
    p = np.atleast_2d(np.asarray(poses, dtype=np.float64))
    if p.shape[-1] != 6:
        raise ValueError(f"poses: expected shape (N, 6), got {p.shape}")
    T = _maps(np.ascontiguousarray(p.reshape(-1, 6)), np.zeros((1, 3)))
    return T.reshape(p.shape[:-1] + (4, 4))


def strained_matrices(poses: ArrayLike, strain: ArrayLike) -> NDArray[np.float64]:
    """Maps (N, 4, 4) of pose vectors (N, 6) whose model plane is strained by ``strain``.

    ``strain`` (3,) or (N, 3) is the in-plane strain ``(e_xx, e_yy, e_xy)`` of the model
    frame: a model point ``(x, y, 0)`` goes to ``(I + E) (x, y)`` before the pose, with ``E =
    [[e_xx, e_xy], [e_xy, e_yy]]`` (symmetric: a rotation stays in the pose). Negative
    strain shrinks the model (cloth gathered by wrinkles). The maps are not rigid; their
    rotation is the pose vector's (the polar factor of ``R (I + E)`` for ``|E| < 1``).
    """
    p = np.atleast_2d(np.asarray(poses, dtype=np.float64))
    if p.ndim != 2 or p.shape[1] != 6:
        raise ValueError(f"poses: expected shape (N, 6), got {p.shape}")
    e = np.asarray(strain, dtype=np.float64)
    if e.shape[-1:] != (3,) or e.size // 3 not in (1, len(p)):
        raise ValueError(f"strain: expected shape (3,) or ({len(p)}, 3), got {e.shape}")
    return _maps(np.ascontiguousarray(p), np.ascontiguousarray(e.reshape(-1, 3)))


@njit
def _maps(p: NDArray[np.float64], e: NDArray[np.float64]
          ) -> NDArray[np.float64]:  # pragma: no cover - numba
    """Maps (N, 4, 4) of pose vectors ``p`` (N, 6) strained by ``e`` (1, 3) or (N, 3): the
    rotation of :func:`_rotations`, its first two columns times ``I + E``, in one compiled
    pass (a few thousand calls a search)."""
    R = _rotations(p, p.shape[1] - 3)    # (not a literal 3: one specialisation for all)
    T = np.zeros((p.shape[0], 4, 4))
    for n in range(p.shape[0]):
        s = e[0] if e.shape[0] == 1 else e[n]
        for i in range(3):
            T[n, i, 0] = R[n, i, 0] * (1.0 + s[0]) + R[n, i, 1] * s[2]
            T[n, i, 1] = R[n, i, 0] * s[2] + R[n, i, 1] * (1.0 + s[1])
            T[n, i, 2] = R[n, i, 2]
            T[n, i, 3] = p[n, i]
        T[n, 3, 3] = 1.0
    return T


def quat_wxyz_from_matrix(R: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternion (4,) in (w, x, y, z) order with w >= 0 from a rotation (3, 3)."""
    x, y, z, w = Rotation.from_matrix(np.asarray(R, dtype=np.float64)[:3, :3]).as_quat()
    q = np.array([w, x, y, z])
    return -q if q[0] < 0 else q


def plane_quat_wxyz(R_cam1_plane: ArrayLike) -> NDArray[np.float64]:
    """:func:`quat_wxyz_from_matrix` of a plane's orientation (3, 3), kept for the last few
    planes: a search lays poses on one rig's facing plane many times a stereo pair, and
    ``Rotation.from_matrix`` costs about half a millisecond a call."""
    R = np.ascontiguousarray(np.asarray(R_cam1_plane, dtype=np.float64)[:3, :3])
    return np.array(_plane_quat_wxyz(R.tobytes()))


@functools.lru_cache(maxsize=16)
def _plane_quat_wxyz(R_bytes: bytes) -> tuple[float, float, float, float]:
    w, a, b, c = quat_wxyz_from_matrix(np.frombuffer(R_bytes, dtype=np.float64).reshape(3, 3))
    return float(w), float(a), float(b), float(c)


def eps_from_rotation(R: ArrayLike) -> NDArray[np.float64]:
    """Quaternion vector part (3,) with non-negative scalar part, inverse of rotation_from_eps."""
    return quat_wxyz_from_matrix(R)[1:]


def in_plane_angle_rad(R: ArrayLike) -> float:
    """Angle of the model x axis about camera 1's z axis: atan2(R[1, 0], R[0, 0]), radians."""
    R = np.asarray(R, dtype=np.float64)
    return float(np.arctan2(R[1, 0], R[0, 0]))


def facing_pose_vectors(flat: ArrayLike, facing: ArrayLike) -> NDArray[np.float64]:
    """Pose vectors (N, 6) of garments lying on a plane of orientation ``R_cam1_facing``.

    Parameters
    ----------
    flat : array (N, 6)
        *Flat* pose vectors ``(x, y, z, -, -, sin(theta / 2))``: position (mm) and in-plane
        angle ``theta`` about the plane's normal; genes 4 and 5 are ignored.
    facing : array (3, 3) or (4,)
        The plane's orientation ``R_cam1_facing`` in camera 1's frame
        (:attr:`StereoRig.R_cam1_facing`), or its ``quat_wxyz`` (the conversion costs more
        than the rest on a GA population); the identity gives the paper's flat poses, square
        to camera 1.

    Returns
    -------
    ndarray (N, 6)
        ``(x, y, z, eps)`` with rotation ``R_cam1_facing @ Rz(theta)``. In closed form (a
        quaternion product): it runs on whole GA populations.
    """
    f = np.atleast_2d(np.asarray(flat, dtype=np.float64))
    if f.ndim != 2 or f.shape[1] != 6:    # the kernel does not check its indices
        raise ValueError(f"flat: expected shape (N, 6), got {np.shape(flat)}")
    q_face = np.asarray(facing, dtype=np.float64)
    w0, a, b, c = plane_quat_wxyz(q_face) if q_face.shape == (3, 3) else q_face
    return _facing(np.ascontiguousarray(f), float(w0), float(a), float(b), float(c))


@njit
def _facing(f: NDArray[np.float64], w0: float, a: float, b: float, c: float
            ) -> NDArray[np.float64]:  # pragma: no cover - numba
    """:func:`facing_pose_vectors` of flat pose vectors ``f`` (N, 6) and the plane's
    quaternion ``(w0, a, b, c)``: one compiled pass (a GA population or an evolution
    strategy's draws, about a hundred calls a search)."""
    out = np.empty((f.shape[0], 6))
    for i in range(f.shape[0]):
        s = f[i, 5]
        ct = math.sqrt(max(1.0 - s * s, 0.0))
        sign = -1.0 if w0 * ct - c * s < 0 else 1.0    # the scalar part stays >= 0
        out[i, 0] = f[i, 0]
        out[i, 1] = f[i, 1]
        out[i, 2] = f[i, 2]
        out[i, 3] = sign * (a * ct + b * s)
        out[i, 4] = sign * (b * ct - a * s)
        out[i, 5] = sign * (w0 * s + c * ct)
    return out


pose_maps_kernel = _maps
"""The numba function behind :func:`pose_vectors_to_matrices` and :func:`strained_matrices`:
``pose_maps_kernel(p, e)`` of pose vectors ``p`` (N, 6) and strains ``e`` (1, 3) or (N, 3),
for numba loops that call it directly (no checks)."""

facing_kernel = _facing
"""The numba function behind :func:`facing_pose_vectors`: ``facing_kernel(f, w, x, y, z)`` of
flat pose vectors ``f`` (N, 6) and the plane's ``quat_wxyz``, for numba loops (no checks)."""


def flat_pose_vectors(poses: ArrayLike, R_cam1_facing: ArrayLike) -> NDArray[np.float64]:
    """Flat pose vectors (N, 6) ``(x, y, z, 0, 0, sin(theta / 2))`` of pose vectors (N, 6):
    ``theta`` is the in-plane angle about the normal of the plane of orientation
    ``R_cam1_facing``; the inverse of :func:`facing_pose_vectors` for poses on that plane."""
    p = np.atleast_2d(np.asarray(poses, dtype=np.float64))
    R = np.asarray(R_cam1_facing, dtype=np.float64).T @ rotation_from_eps(p[:, 3:])
    theta = np.arctan2(R[:, 1, 0], R[:, 0, 0])
    return np.column_stack([p[:, :3], np.zeros((len(p), 2)), np.sin(theta / 2)])
