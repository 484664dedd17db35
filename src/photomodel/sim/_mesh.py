"""Wrinkled garments: a non-planar cloth surface and a z-buffered triangle-mesh renderer.

A garment's *material* coordinates ``m = (x, y)`` (mm) are the points of its flat texture frame
(origin at the silhouette's area centroid). A :class:`Wrinkles` field maps each material point
to its place on the table, in the garment frame:

``P(m) = (m + sum_k delta_k(m) n_k,  -h(m))``

where ``h >= 0`` is the height above the table (the frame's z points into the table, so lifted
cloth has negative z), made of a few *folds* (ridges with a Gaussian cross-section, fading out
along their length) plus a broad undulation, and ``delta_k`` pulls the cloth towards fold ``k``'s
crest by the extra arc length the fold uses, so a wrinkled garment covers less of the table than a
flat one, as real cloth does. The true pose of a wrinkled garment is the pose of this garment
frame (where the flat garment would lie).

:func:`render_mesh_layer` renders such a surface: the field is sampled on a regular grid of
material points (every ``step_mm``), triangulated, projected through the camera (distortion
included, exactly, at the vertices), and rasterised with a z-buffer at sub-pixel resolution by a
numba kernel; inside each triangle texture coordinates and Lambertian shading are interpolated
linearly in the image (piecewise-affine warping; triangles are 2-4 sub-pixels across, so the
warp error is far below a pixel).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel._jit import njit
from photomodel.camera import PinholeCamera
from photomodel.sim._textures import PlaneTexture, RngLike

__all__ = ["Fold", "Wrinkles", "field_of_view_radius", "make_wrinkles", "render_mesh_layer"]


@dataclass(frozen=True)
class Fold:
    """One fold of cloth: a ridge of Gaussian cross-section that fades out along its length.

    Parameters
    ----------
    centre_mm : (float, float)
        Middle of the crest in material coordinates, mm.
    angle_rad : float
        Direction of the crest from the material x axis, radians.
    length_mm : float
        Length of the crest (the height falls to ``exp(-1)`` at ``length_mm / 2`` from the centre).
    width_mm : float
        Standard deviation of the Gaussian cross-section, mm.
    height_mm : float
        Height of the crest above the table, mm.
    """

    centre_mm: tuple[float, float]
    angle_rad: float
    length_mm: float
    width_mm: float
    height_mm: float


_PROFILE_D = np.linspace(0.0, 8.0, 801)  # |d| / width: cross-section table for the gathering


def _gathered_excess(slope_scale: float) -> NDArray[np.float64]:
    """Extra arc length L(|d|) / width of a unit-width Gaussian ridge, table on _PROFILE_D."""
    dh = slope_scale * _PROFILE_D * np.exp(-0.5 * _PROFILE_D**2)  # h'(d) for h = s exp(-d^2/2)
    integrand = np.sqrt(1.0 + dh**2) - 1.0
    steps = 0.5 * (integrand[1:] + integrand[:-1]) * np.diff(_PROFILE_D)
    return np.concatenate([[0.0], np.cumsum(steps)])


@dataclass(frozen=True)
class Wrinkles:
    """A wrinkled cloth surface over a garment's material coordinates.

    Parameters
    ----------
    folds : tuple of Fold
        The folds.
    undulation_mm : float
        Amplitude of the broad undulation, mm (heights stay >= 0).
    undulation_phase : (float, float, float, float)
        Phases (radians) of the undulation's two waves and their directions.
    undulation_wavelength_mm : float
        Wavelength of the undulation, mm.
    """

    folds: tuple[Fold, ...]
    undulation_mm: float = 0.0
    undulation_phase: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    undulation_wavelength_mm: float = 120.0

    def surface_mm(self, material_mm: ArrayLike) -> NDArray[np.float64]:
        """Points (N, 3) in the garment frame, mm, of material points (N, 2), mm."""
        m = np.asarray(material_mm, dtype=np.float64).reshape(-1, 2)
        xy = m.copy()
        h = np.zeros(len(m))
        for fold in self.folds:
            c, s = np.cos(fold.angle_rad), np.sin(fold.angle_rad)
            rel = m - np.asarray(fold.centre_mm)
            along = rel @ np.array([c, s])
            across = rel @ np.array([-s, c])
            envelope = np.exp(-((2.0 * along / fold.length_mm) ** 4))
            d = across / fold.width_mm
            h += fold.height_mm * envelope * np.exp(-0.5 * d**2)
            excess = np.interp(np.abs(d), _PROFILE_D,
                               _gathered_excess(fold.height_mm / fold.width_mm))
            shift = -np.sign(d) * excess * fold.width_mm * envelope
            xy += shift[:, None] * np.array([-s, c])
        if self.undulation_mm > 0:
            p1, p2, a1, a2 = self.undulation_phase
            k = 2.0 * np.pi / self.undulation_wavelength_mm
            w1 = np.sin(k * (m @ np.array([np.cos(a1), np.sin(a1)])) + p1)
            w2 = np.sin(k * (m @ np.array([np.cos(a2), np.sin(a2)])) + p2)
            h += 0.5 * self.undulation_mm * (1.0 + 0.5 * (w1 + w2))
        return np.column_stack([xy, -h])


def make_wrinkles(
    texture: PlaneTexture,
    rng: RngLike = None,
    height_mm: float = 6.0,
    n_folds: int | None = None,
) -> Wrinkles:
    """Random folds over a garment: crests of ``height_mm * (0.5 .. 1)``, 4-9 mm wide.

    Parameters
    ----------
    texture : PlaneTexture
        The garment's texture (its alpha is the silhouette); folds are centred on the cloth.
    rng : int or Generator, optional
        Seed or generator.
    height_mm : float
        Largest crest height, mm (0: a flat garment).
    n_folds : int, optional
        Number of folds (default: 2 to 5, drawn).
    """
    if height_mm < 0:
        raise ValueError(f"height_mm: expected >= 0, got {height_mm}")
    gen = np.random.default_rng(rng)
    n = int(gen.integers(2, 6)) if n_folds is None else int(n_folds)
    v, u = np.nonzero(texture.alpha > 0.5)
    if len(u) == 0:
        raise ValueError("texture: the garment's alpha is empty")
    cloth_mm = texture.mm_from_px(np.column_stack([u, v]).astype(np.float64))
    span = float(np.max(np.ptp(cloth_mm, axis=0)))
    folds = []
    for _ in range(n):
        centre = cloth_mm[gen.integers(len(cloth_mm))]
        folds.append(Fold((float(centre[0]), float(centre[1])), float(gen.uniform(0, np.pi)),
                          float(gen.uniform(0.3, 0.8) * span), float(gen.uniform(4.0, 9.0)),
                          float(height_mm * gen.uniform(0.5, 1.0))))
    phase = tuple(float(p) for p in gen.uniform(0.0, 2.0 * np.pi, 4))
    return Wrinkles(tuple(folds), 0.3 * height_mm, phase, float(gen.uniform(90.0, 160.0)))


@lru_cache(maxsize=16)
def _fov_radius_cached(K: bytes, dist: bytes, width: int, height: int) -> float:
    camera = PinholeCamera(np.frombuffer(K).reshape(3, 3), np.frombuffer(dist), width, height)
    u = np.linspace(-0.5, width - 0.5, 33)
    v = np.linspace(-0.5, height - 0.5, 25)
    border = np.concatenate([np.column_stack([u, np.full_like(u, v[0])]),
                             np.column_stack([u, np.full_like(u, v[-1])]),
                             np.column_stack([np.full_like(v, u[0]), v]),
                             np.column_stack([np.full_like(v, u[-1]), v])])
    xy = camera.undistort_pixels(border)
    return float(np.nanmax(np.hypot(xy[:, 0], xy[:, 1])))


def field_of_view_radius(camera: PinholeCamera, margin: float = 1.05) -> float:
    """Largest normalised ray radius (X/Z, Y/Z) the image border sees, times ``margin``.

    Points beyond it are outside the image; the renderers skip them rather than trust a
    distortion polynomial out there (it can fold back into the image).
    """
    return margin * _fov_radius_cached(camera.K.tobytes(), camera.dist.tobytes(),
                                       camera.width_px, camera.height_px)


@njit
def _rasterize(xy: NDArray[np.float64], depth: NDArray[np.float64], attr: NDArray[np.float32],
               tris: NDArray[np.int32], zbuf: NDArray[np.float64], out: NDArray[np.float32],
               covered: NDArray[np.bool_]) -> None:  # pragma: no cover - numba
    """Z-buffered scan of triangles; pixel (x, y) has its centre at integer (x, y)."""
    height, width = zbuf.shape
    n_attr = attr.shape[1]
    for t in range(tris.shape[0]):
        i0, i1, i2 = tris[t, 0], tris[t, 1], tris[t, 2]
        x0, y0, x1, y1, x2, y2 = xy[i0, 0], xy[i0, 1], xy[i1, 0], xy[i1, 1], xy[i2, 0], xy[i2, 1]
        if not (np.isfinite(x0) and np.isfinite(x1) and np.isfinite(x2)
                and np.isfinite(y0) and np.isfinite(y1) and np.isfinite(y2)):
            continue
        area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
        if abs(area) < 1e-12:
            continue
        xmin = max(int(np.ceil(min(x0, x1, x2))), 0)
        xmax = min(int(np.floor(max(x0, x1, x2))), width - 1)
        ymin = max(int(np.ceil(min(y0, y1, y2))), 0)
        ymax = min(int(np.floor(max(y0, y1, y2))), height - 1)
        for y in range(ymin, ymax + 1):
            for x in range(xmin, xmax + 1):
                w0 = ((x1 - x) * (y2 - y) - (x2 - x) * (y1 - y)) / area
                w1 = ((x2 - x) * (y0 - y) - (x0 - x) * (y2 - y)) / area
                w2 = 1.0 - w0 - w1
                if w0 < -1e-9 or w1 < -1e-9 or w2 < -1e-9:
                    continue
                z = w0 * depth[i0] + w1 * depth[i1] + w2 * depth[i2]
                if z < zbuf[y, x]:
                    zbuf[y, x] = z
                    covered[y, x] = True
                    for k in range(n_attr):
                        out[y, x, k] = w0 * attr[i0, k] + w1 * attr[i1, k] + w2 * attr[i2, k]


def _grid(texture: PlaneTexture, step_mm: float
          ) -> tuple[NDArray[np.float64], NDArray[np.int32], tuple[int, int]]:
    """Material points (V, 2) on a grid over the whole texture, its triangles (T, 3), (nx, ny)."""
    w_mm, h_mm = texture.size_mm
    lo = texture.mm_from_px([-0.5, -0.5])
    nx = int(np.ceil(w_mm / step_mm)) + 1
    ny = int(np.ceil(h_mm / step_mm)) + 1
    xs = lo[0] + np.linspace(0.0, w_mm, nx)
    ys = lo[1] + np.linspace(0.0, h_mm, ny)
    gx, gy = np.meshgrid(xs, ys)
    material = np.column_stack([gx.ravel(), gy.ravel()])
    idx = np.arange(nx * ny, dtype=np.int32).reshape(ny, nx)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    tris = np.concatenate([np.stack([a, b, d], -1), np.stack([a, d, c], -1)]).astype(np.int32)
    return material, tris, (nx, ny)


def _normals(points: NDArray[np.float64], shape: tuple[int, int]) -> NDArray[np.float64]:
    """Unit surface normals (V, 3) of a grid surface, pointing to -z (towards the viewer)."""
    nx, ny = shape
    p = points.reshape(ny, nx, 3)
    du = np.gradient(p, axis=1)
    dv = np.gradient(p, axis=0)
    n = np.cross(du, dv)  # x-step cross y-step: +z for a flat sheet; flip to face the viewer
    n = -n / np.linalg.norm(n, axis=-1, keepdims=True)
    return n.reshape(-1, 3)


def render_mesh_layer(
    camera: PinholeCamera,
    T_cam_item: NDArray[np.float64],
    texture: PlaneTexture,
    wrinkles: Wrinkles,
    supersample: int,
    light_dir_cam: ArrayLike = (0.35, -0.45, 0.82),
    ambient: float = 0.45,
    step_mm: float = 1.5,
) -> tuple[NDArray[np.float32], tuple[slice, slice]]:
    """Render a wrinkled textured surface: premultiplied colour and coverage at sub-pixels.

    Parameters
    ----------
    camera : PinholeCamera
        Camera with its image size set.
    T_cam_item : ndarray (4, 4)
        Pose of the garment frame in the camera frame, mm.
    texture : PlaneTexture
        The garment's texture and silhouette (alpha), in material coordinates.
    wrinkles : Wrinkles
        The surface.
    supersample : int
        Sub-pixels per pixel along each axis.
    light_dir_cam : (3,)
        Direction towards the light, camera frame.
    ambient : float
        Share of ambient light; the rest is Lambertian, normalised so that flat cloth facing the
        camera keeps the texture's colour.
    step_mm : float
        Mesh spacing in material coordinates, mm.

    Returns
    -------
    layer : ndarray (h, w, 4) float32
        Premultiplied (B, G, R, alpha) of the surface over the region of interest of the
        supersampled image (``H*s x W*s``) that the mesh covers; alpha = texture alpha where the
        mesh covers the sub-pixel, else 0.
    roi : (slice, slice)
        Rows and columns of that region in the supersampled image.
    """
    s = int(supersample)
    material, tris, shape = _grid(texture, step_mm)
    points = wrinkles.surface_mm(material)
    R, t = T_cam_item[:3, :3], T_cam_item[:3, 3]
    points_cam = points @ R.T + t
    normals_cam = _normals(points, shape) @ R.T
    light = np.asarray(light_dir_cam, dtype=np.float64)
    light = light / np.linalg.norm(light)
    lambert = np.clip(normals_cam @ light, 0.0, None)
    flat = max(float(-R[:, 2] @ light), 1e-3)  # a flat sheet's normal is -z of the item frame
    shade = (ambient + (1.0 - ambient) * lambert) / (ambient + (1.0 - ambient) * flat)
    depth = points_cam[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        radius = np.hypot(points_cam[:, 0], points_cam[:, 1]) / depth
    usable = (depth > 1e-6) & (radius <= field_of_view_radius(camera))
    xy = np.full((len(points_cam), 2), np.nan)
    if usable.any():
        xy[usable] = (camera.project(points_cam[usable]) + 0.5) * s - 0.5
    h, w = camera.height_px * s, camera.width_px * s
    if not usable.any():
        return np.zeros((0, 0, 4), np.float32), (slice(0, 0), slice(0, 0))
    c0 = max(int(np.floor(np.nanmin(xy[:, 0]))) - 1, 0)
    c1 = min(int(np.ceil(np.nanmax(xy[:, 0]))) + 2, w)
    r0 = max(int(np.floor(np.nanmin(xy[:, 1]))) - 1, 0)
    r1 = min(int(np.ceil(np.nanmax(xy[:, 1]))) + 2, h)
    if c0 >= c1 or r0 >= r1:
        return np.zeros((0, 0, 4), np.float32), (slice(0, 0), slice(0, 0))
    xy -= (c0, r0)
    tex_uv = texture.px_from_mm(material)
    attr = np.column_stack([tex_uv, shade]).astype(np.float32)
    zbuf = np.full((r1 - r0, c1 - c0), np.inf)
    out = np.zeros((r1 - r0, c1 - c0, 3), np.float32)
    covered = np.zeros((r1 - r0, c1 - c0), np.bool_)
    _rasterize(xy, depth, attr, tris, zbuf, out, covered)
    map_u = np.where(covered, out[..., 0], -16.0).astype(np.float32)
    map_v = np.where(covered, out[..., 1], -16.0).astype(np.float32)
    layer = texture.sample_premultiplied(map_u, map_v)
    layer[..., :3] *= out[..., 2:3]
    return layer, (slice(r0, r1), slice(c0, c1))
