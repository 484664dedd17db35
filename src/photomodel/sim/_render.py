"""Renderer of textured items over a plane, seen by a distorted pinhole camera.

Flat items (the table, flat garments, the faces of a box, a gripper) are rendered by exact
inverse mapping: every (sub-)pixel's ray comes from :meth:`PinholeCamera.undistort_pixels`,
the exact inverse of the camera's distortion, and is intersected with the plane; so a texture
point lands where :meth:`PinholeCamera.project` says, up to texture interpolation (a small
fraction of a pixel). Layers are sampled with ``cv2.remap`` (bilinear, transparent outside the
texture), composited with premultiplied alpha and area-averaged over ``s x s`` sub-pixels.
Wrinkled garments are meshes rendered by :mod:`photomodel.sim._mesh`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel._jit import njit
from photomodel.camera import PinholeCamera
from photomodel.sim._mesh import Wrinkles, field_of_view_radius, render_mesh_layer
from photomodel.sim._textures import PlaneTexture, RngLike

__all__ = [
    "DEFAULT_LIGHT_DIR",
    "Layer",
    "RenderedView",
    "add_sensor_noise",
    "blur",
    "pixel_rays",
    "render_view",
    "render_view_linear",
]

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


@njit(parallel=True)
def _texture_maps(rays: NDArray[np.float64], R: NDArray[np.float64], p0: NDArray[np.float64],
                  origin_px: NDArray[np.float64], mm_per_px: float
                  ) -> tuple[NDArray[np.float32], NDArray[np.float32]]:  # pragma: no cover
    """Texture pixel maps (H, W) of rays (H, W, 2) meeting the plane z = 0 of a frame.

    ``R``, ``p0``: the frame's pose in the camera frame. Rays that miss the plane (NaN rays,
    parallel, or meeting it behind the camera) map to a texture pixel outside every texture.
    """
    height, width = rays.shape[0], rays.shape[1]
    map_u = np.empty((height, width), np.float32)
    map_v = np.empty((height, width), np.float32)
    n0, n1, n2 = R[0, 2], R[1, 2], R[2, 2]
    num = n0 * p0[0] + n1 * p0[1] + n2 * p0[2]
    for i in numba.prange(height):
        for j in range(width):
            rx, ry = rays[i, j, 0], rays[i, j, 1]
            denom = rx * n0 + ry * n1 + n2
            depth = num / denom if denom != 0.0 else -1.0
            if not depth > 0.0:  # also catches NaN
                map_u[i, j] = _OUTSIDE
                map_v[i, j] = _OUTSIDE
                continue
            dx, dy, dz = rx * depth - p0[0], ry * depth - p0[1], depth - p0[2]
            x = R[0, 0] * dx + R[1, 0] * dy + R[2, 0] * dz
            y = R[0, 1] * dx + R[1, 1] * dy + R[2, 1] * dz
            map_u[i, j] = x / mm_per_px + origin_px[0]
            map_v[i, j] = y / mm_per_px + origin_px[1]
    return map_u, map_v


def _maps(rays: NDArray[np.float64], T_cam_item: NDArray[np.float64],
          texture: PlaneTexture) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    return _texture_maps(rays, np.ascontiguousarray(T_cam_item[:3, :3]),
                         np.ascontiguousarray(T_cam_item[:3, 3]), texture.origin_px,
                         texture.mm_per_px)


def _sample_opaque(texture: PlaneTexture, map_u: NDArray[np.float32],
                   map_v: NDArray[np.float32]) -> NDArray[np.float32]:
    """(B, G, R) (H, W, 3) of an opaque texture; black outside it."""
    return cv2.remap(texture.image_bgr.astype(np.float32), map_u, map_v, cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=0)


DEFAULT_LIGHT_DIR: tuple[float, float, float] = (0.3, -0.4, -0.87)
"""Default direction *towards* the light in the plane's frame (z into the table): above, oblique."""


@dataclass(frozen=True)
class Layer:
    """A textured item in the scene.

    Parameters
    ----------
    texture : PlaneTexture
        Its picture and silhouette (alpha), in the item frame's z = 0 plane.
    T_plane_item : ndarray (4, 4)
        Pose of the item frame in the plane (table) frame, mm: any rigid transform (items may
        be lifted above the table or stand on edge, like the side of a box).
    wrinkles : Wrinkles, optional
        A non-planar cloth surface (rendered as a mesh); None for a flat item.
    cull_back : bool
        Skip the item in cameras that see its back (+z) side: the faces of a solid.
    """

    texture: PlaneTexture
    T_plane_item: NDArray[np.float64]
    wrinkles: Wrinkles | None = None
    cull_back: bool = False


@dataclass(frozen=True)
class RenderedView:
    """What :func:`render_view_linear` returns.

    Parameters
    ----------
    image : ndarray (H, W, 3) float32
        BGR, 0-255 scale, not rounded or clipped (shading may exceed 255).
    coverage : ndarray (H, W) float32 or None
        Coverage in [0, 1] of the tracked layer by itself; None when no single layer was
        tracked (``track`` None or a sequence).
    visible : ndarray (H, W) float32 or None
        Visible coverage of the tracked layer (its coverage times what no later layer hides).
    coverages : tuple of ndarray (H, W) float32
        With ``track`` a sequence of indices: each tracked layer's coverage, in the order of
        ``track``; empty otherwise.
    visibles : tuple of ndarray (H, W) float32
        With ``track`` a sequence: each tracked layer's visible coverage, in the same order.
    """

    image: NDArray[np.float32]
    coverage: NDArray[np.float32] | None = None
    visible: NDArray[np.float32] | None = None
    coverages: tuple[NDArray[np.float32], ...] = ()
    visibles: tuple[NDArray[np.float32], ...] = ()


def _as_layer(item: Layer | tuple[ArrayLike, PlaneTexture]) -> Layer:
    if isinstance(item, Layer):
        return item
    T, texture = item
    return Layer(texture, np.asarray(T, dtype=np.float64))


def _flat_shade(T_plane_item: NDArray[np.float64], light: NDArray[np.float64],
                ambient: float) -> float:
    """Lambertian brightness of a flat item relative to the table (1 for items parallel to it)."""
    normal = -T_plane_item[:3, 2]  # the item's -z faces the viewer, like the table's
    ref = max(float(-light[2]), 1e-3)
    lam = abs(float(normal @ light))
    return (ambient + (1.0 - ambient) * lam) / (ambient + (1.0 - ambient) * ref)


Roi = tuple[slice, slice]


def _flat_roi(camera: PinholeCamera, T_cam_item: NDArray[np.float64], texture: PlaneTexture,
              supersample: int) -> Roi:
    """Sub-pixel rows and columns that can see a flat item: its texture rectangle's image bbox.

    The whole image when part of the rectangle lies behind the camera or beyond the image's
    field of view (where a distortion polynomial may fold back).
    """
    s = supersample
    full = (slice(0, camera.height_px * s), slice(0, camera.width_px * s))
    w, h = texture.size_px
    t = np.linspace(0.0, 1.0, 25)[:, None]
    corners = np.array([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])
    edges = np.concatenate([a + t * (b - a) for a, b in
                            zip(corners, np.roll(corners, -1, axis=0), strict=True)])
    pts = np.column_stack([texture.mm_from_px(edges), np.zeros(len(edges))])
    cam = pts @ T_cam_item[:3, :3].T + T_cam_item[:3, 3]
    if np.any(cam[:, 2] <= 1e-6):
        return full
    radius = np.hypot(cam[:, 0] / cam[:, 2], cam[:, 1] / cam[:, 2])
    if np.any(radius > field_of_view_radius(camera)):
        return full
    uv = (camera.project(cam) + 0.5) * s - 0.5
    c0 = max(int(np.floor(uv[:, 0].min())) - 2, 0)
    c1 = min(int(np.ceil(uv[:, 0].max())) + 3, camera.width_px * s)
    r0 = max(int(np.floor(uv[:, 1].min())) - 2, 0)
    r1 = min(int(np.ceil(uv[:, 1].max())) + 3, camera.height_px * s)
    if c0 >= c1 or r0 >= r1:
        return (slice(0, 0), slice(0, 0))
    return (slice(r0, r1), slice(c0, c1))


def render_view_linear(
    camera: PinholeCamera,
    T_cam_plane: ArrayLike,
    background: PlaneTexture,
    items: Sequence[Layer | tuple[ArrayLike, PlaneTexture]] = (),
    *,
    supersample: int = 2,
    track: int | Sequence[int] | None = None,
    light_dir_plane: ArrayLike = DEFAULT_LIGHT_DIR,
    ambient: float = 0.45,
) -> RenderedView:
    """Render textured items over a plane as the camera sees them (floating point).

    Flat items are rendered exactly by inverse mapping (every sub-pixel's ray through the exact
    inverse of the lens distortion, met with the item's plane); wrinkled items as z-buffered
    meshes (:func:`render_mesh_layer`). Items are composited in order, later ones on top (the
    caller orders them by height).

    Parameters
    ----------
    camera : PinholeCamera
        Camera with its image size set; its distortion is honoured exactly.
    T_cam_plane : ndarray (4, 4)
        Pose of the plane frame in the camera frame, mm.
    background : PlaneTexture
        Bottom layer, its texture frame equal to the plane frame.
    items : sequence of Layer or (T_plane_item (4, 4), PlaneTexture)
        Items on top, later ones above earlier ones.
    supersample : int
        Sub-pixels per pixel along each axis; their colours are averaged (anti-aliasing).
    track : int or sequence of int, optional
        Index into ``items`` of a layer whose coverage and visible coverage are returned
        (``coverage``, ``visible``); or several indices, each layer's returned in
        ``coverages`` and ``visibles`` (one render gives every garment's visibility).
    light_dir_plane : (3,)
        Direction towards the (distant) light in the plane frame; shades wrinkles and items
        not parallel to the plane.
    ambient : float
        Share of ambient light in the shading.

    Returns
    -------
    RenderedView
    """
    T_cam_plane = _check_transform(T_cam_plane, "T_cam_plane")
    layers = [_as_layer(item) for item in items]
    for k, layer in enumerate(layers):
        _check_transform(layer.T_plane_item, f"items[{k}]")
    single = track is None or isinstance(track, int | np.integer)
    tracked = [] if track is None else [int(track)] if single else [int(k) for k in track]
    for k in tracked:
        if not 0 <= k < len(layers):
            raise ValueError(f"track: expected an index into items, got {track}")
    if len(set(tracked)) != len(tracked):
        raise ValueError(f"track: expected distinct indices, got {track}")
    light = np.asarray(light_dir_plane, dtype=np.float64)
    light = light / np.linalg.norm(light)
    rays = pixel_rays(camera, supersample)
    if bool(np.all(background.alpha == 1.0)):
        image = _sample_opaque(background, *_maps(rays, T_cam_plane, background))
    else:
        image = background.sample_premultiplied(*_maps(rays, T_cam_plane, background))[..., :3]
    coverage: dict[int, NDArray[np.float32]] = {}  # of the tracked layers drawn so far
    visible: dict[int, NDArray[np.float32]] = {}
    for k, layer in enumerate(layers):
        T_cam_item = T_cam_plane @ layer.T_plane_item
        if layer.cull_back and float(T_cam_item[:3, 2] @ T_cam_item[:3, 3]) <= 0.0:
            if k in tracked and not single:
                coverage[k] = np.zeros(image.shape[:2], np.float32)
                visible[k] = coverage[k].copy()
            continue
        if layer.wrinkles is not None:
            sampled, roi = render_mesh_layer(camera, T_cam_item, layer.texture, layer.wrinkles,
                                             supersample, T_cam_plane[:3, :3] @ light, ambient)
        else:
            roi = _flat_roi(camera, T_cam_item, layer.texture, supersample)
            sampled = layer.texture.sample_premultiplied(
                *_maps(rays[roi], T_cam_item, layer.texture))
            shade = _flat_shade(layer.T_plane_item, light, ambient)
            if shade != 1.0:
                sampled[..., :3] *= shade
        alpha = sampled[..., 3:]
        image[roi] = sampled[..., :3] + (1.0 - alpha) * image[roi]
        for seen in visible.values():
            seen[roi] *= 1.0 - alpha[..., 0]
        if k in tracked:
            coverage[k] = np.zeros(image.shape[:2], np.float32)
            coverage[k][roi] = alpha[..., 0]
            visible[k] = coverage[k].copy()
    if supersample > 1:
        size = (camera.width_px, camera.height_px)
        image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
        for masks in (coverage, visible):
            for k in masks:
                masks[k] = cv2.resize(masks[k], size, interpolation=cv2.INTER_AREA)
    image = image.astype(np.float32)
    if single:
        k = tracked[0] if tracked else -1
        return RenderedView(image, coverage.get(k), visible.get(k))
    return RenderedView(image, coverages=tuple(coverage[k] for k in tracked),
                        visibles=tuple(visible[k] for k in tracked))


def render_view(
    camera: PinholeCamera,
    T_cam_plane: ArrayLike,
    background: PlaneTexture,
    items: Sequence[Layer | tuple[ArrayLike, PlaneTexture]] = (),
    *,
    supersample: int = 2,
) -> NDArray[np.uint8]:
    """Render items over a plane as the camera sees them, as an 8-bit BGR image.

    :func:`render_view_linear` rounded and clipped to uint8 (same parameters); black where no
    opaque layer is seen (rays missing the plane, or meeting it behind the camera).
    """
    view = render_view_linear(camera, T_cam_plane, background, items, supersample=supersample)
    return np.clip(np.rint(view.image), 0, 255).astype(np.uint8)


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
