"""Exact renderer of flat textures lying in one plane, seen by a distorted pinhole camera.

Inverse mapping: every (sub-)pixel's ray comes from :meth:`PinholeCamera.undistort_pixels`,
the exact inverse of the camera's distortion, and is intersected with the plane; so a texture
point lands where :meth:`PinholeCamera.project` says, up to texture interpolation (a small
fraction of a pixel). Layers are sampled with ``cv2.remap`` (bilinear, transparent outside the
texture), composited with premultiplied alpha and area-averaged over ``s x s`` sub-pixels.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel.camera import PinholeCamera
from photomodel.geometry import invert_transform
from photomodel.sim._textures import PlaneTexture, RngLike

__all__ = ["add_sensor_noise", "blur", "pixel_rays", "render_view"]

_OUTSIDE = -16.0  # texture coordinate that samples only the transparent border


def _check_transform(T: ArrayLike, name: str) -> NDArray[np.float64]:
    T = np.asarray(T, dtype=np.float64)
    if T.shape != (4, 4) or not np.isfinite(T).all():
        raise ValueError(f"{name}: expected a finite (4, 4) transform, got shape {T.shape}")
    R = T[:3, :3]
    if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) <= 0:
        raise ValueError(f"{name}: rotation part is not a rotation matrix")
    return T


@lru_cache(maxsize=6)  # about 20 MB each at 640 x 480, s = 2
def _rays_cached(K: bytes, dist: bytes, width: int, height: int,
                 supersample: int) -> NDArray[np.float64]:
    camera = PinholeCamera(np.frombuffer(K).reshape(3, 3), np.frombuffer(dist), width, height)
    s = supersample
    u = (np.arange(width * s) + 0.5) / s - 0.5
    v = (np.arange(height * s) + 0.5) / s - 0.5
    uu, vv = np.meshgrid(u, v)
    xy = camera.undistort_pixels(np.stack([uu.ravel(), vv.ravel()], axis=-1))
    rays = xy.reshape(height * s, width * s, 2)
    rays.flags.writeable = False
    return rays


def pixel_rays(camera: PinholeCamera, supersample: int = 1) -> NDArray[np.float64]:
    """Normalised rays (H*s, W*s, 2) = (X/Z, Y/Z) through the sub-pixel centres of a camera.

    Sub-pixel ``i`` of ``s`` per pixel sits at ``u = (i + 0.5) / s - 0.5`` (pixel units, origin at
    the centre of the top-left pixel); likewise for ``v``. Cached per camera and ``s``; the
    returned array is read-only. NaN where the distortion cannot be inverted.
    """
    if camera.width_px < 1 or camera.height_px < 1:
        raise ValueError("camera: width_px and height_px must be set to render")
    if int(supersample) < 1:
        raise ValueError(f"supersample: expected an integer >= 1, got {supersample}")
    return _rays_cached(camera.K.tobytes(), camera.dist.tobytes(), camera.width_px,
                        camera.height_px, int(supersample))


def _plane_points(rays: NDArray[np.float64], T_cam_plane: NDArray[np.float64]
                  ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Plane-frame (x, y) (..., 2) mm where the rays meet the plane z = 0, and where they do."""
    R, p0 = T_cam_plane[:3, :3], T_cam_plane[:3, 3]
    n = R[:, 2]
    denom = rays[..., 0] * n[0] + rays[..., 1] * n[1] + n[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = np.dot(n, p0) / denom  # Z of the hit point in the camera frame
    hit = depth > 0  # False for NaN, rays parallel to the plane and hits behind the camera
    depth = np.where(hit, depth, 0.0)
    dx, dy, dz = rays[..., 0] * depth - p0[0], rays[..., 1] * depth - p0[1], depth - p0[2]
    xy = np.stack([R[0, 0] * dx + R[1, 0] * dy + R[2, 0] * dz,
                   R[0, 1] * dx + R[1, 1] * dy + R[2, 1] * dz], axis=-1)
    return xy, hit


def _sample(texture: PlaneTexture, xy_item: NDArray[np.float64],
            hit: NDArray[np.bool_]) -> NDArray[np.float32]:
    """Premultiplied (B, G, R, alpha) (..., 4) of a texture at item-frame points (..., 2), mm."""
    uv = texture.px_from_mm(xy_item)
    uv[~hit] = _OUTSIDE
    a = texture.alpha[..., None]
    layer = np.concatenate([texture.image_bgr.astype(np.float32) * a, a], axis=-1)
    return cv2.remap(layer, uv[..., 0].astype(np.float32), uv[..., 1].astype(np.float32),
                     cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)


def render_view(
    camera: PinholeCamera,
    T_cam_plane: ArrayLike,
    background: PlaneTexture,
    items: Sequence[tuple[ArrayLike, PlaneTexture]] = (),
    *,
    supersample: int = 2,
) -> NDArray[np.uint8]:
    """Render flat textures lying in one plane as the camera sees them.

    Parameters
    ----------
    camera : PinholeCamera
        Camera with its image size set; its distortion is honoured exactly.
    T_cam_plane : ndarray (4, 4)
        Pose of the plane frame in the camera frame, mm; everything lies at z = 0 of the plane.
    background : PlaneTexture
        Bottom layer, its texture frame equal to the plane frame.
    items : sequence of (T_plane_item (4, 4), PlaneTexture)
        Layers on top, later ones above earlier ones, each placed by an in-plane rigid
        transform (rotation about z, translation in x and y) of its texture frame.
    supersample : int
        Sub-pixels per pixel along each axis; their colours are averaged (anti-aliasing).

    Returns
    -------
    ndarray (height_px, width_px, 3) uint8
        BGR image; black where no opaque layer is seen (rays missing the plane, or meeting it
        behind the camera).
    """
    T_cam_plane = _check_transform(T_cam_plane, "T_cam_plane")
    placed = []
    for k, (T_plane_item, texture) in enumerate(items):
        T = _check_transform(T_plane_item, f"items[{k}]")
        if not np.allclose(T[2], [0.0, 0.0, 1.0, 0.0], atol=1e-9):
            raise ValueError(f"items[{k}]: T_plane_item must keep the item in the plane z = 0")
        placed.append((invert_transform(T), texture))
    xy, hit = _plane_points(pixel_rays(camera, supersample), T_cam_plane)
    image = _sample(background, xy, hit)[..., :3]
    for T_item_plane, texture in placed:
        xy_item = xy @ T_item_plane[:2, :2].T + T_item_plane[:2, 3]
        layer = _sample(texture, xy_item, hit)
        image = layer[..., :3] + (1.0 - layer[..., 3:]) * image
    if supersample > 1:
        image = cv2.resize(image, (camera.width_px, camera.height_px),
                           interpolation=cv2.INTER_AREA)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def add_sensor_noise(image: NDArray[np.uint8], sigma: float,
                     rng: RngLike = None) -> NDArray[np.uint8]:
    """Add white Gaussian noise of std ``sigma`` grey levels; rounded and clipped to uint8."""
    if sigma <= 0:
        return image.copy()
    noise = np.random.default_rng(rng).normal(0.0, sigma, image.shape)
    return np.clip(np.rint(image + noise), 0, 255).astype(np.uint8)


def blur(image: NDArray[np.uint8], sigma_px: float) -> NDArray[np.uint8]:
    """Gaussian optical blur of std ``sigma_px`` pixels (a copy when ``sigma_px <= 0``)."""
    if sigma_px <= 0:
        return image.copy()
    return cv2.GaussianBlur(image, (0, 0), sigma_px)
