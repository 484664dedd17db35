"""Ready-made synthetic data: model-station photos and stereo scenes with ground truth."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from photomodel.camera import PinholeCamera, StereoRig
from photomodel.geometry import make_transform, transform_points
from photomodel.sim._conditions import Conditions, expose
from photomodel.sim._garments import Garment
from photomodel.sim._mesh import Wrinkles, make_wrinkles
from photomodel.sim._objects import OBJECT_KINDS, gripper, make_object, place_layers
from photomodel.sim._render import Layer, add_sensor_noise, blur, render_view, render_view_linear
from photomodel.sim._rigs import MODEL_DISTANCE_MM, hand_table_pose
from photomodel.sim._tables import make_table
from photomodel.sim._textures import (
    MODEL_GREEN_BGR,
    PlaneTexture,
    RngLike,
    table_plane,
    uniform_plane,
)

__all__ = [
    "POSITION_RANGE_MM",
    "THETA_RANGE_DEG",
    "SimulatedScene",
    "StereoScene",
    "garment_placement",
    "random_stereo_scene",
    "render_model_photos",
    "render_stereo_scene",
    "simulate_scene",
]


def garment_placement(x_mm: float, y_mm: float, theta_deg: float) -> NDArray[np.float64]:
    """In-plane placement ``T_plane_garment`` (4, 4): rotation ``theta_deg`` about z, then shift."""
    c, s = np.cos(np.radians(theta_deg)), np.sin(np.radians(theta_deg))
    return make_transform([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]], [x_mm, y_mm, 0.0])


def render_model_photos(
    garment: Garment,
    camera: PinholeCamera,
    rng: RngLike = None,
    noise_sigma: float = 1.5,
    *,
    offset_mm: tuple[float, float] = (6.0, -4.0),
    blur_sigma_px: float = 0.5,
) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """The model station's two photos: the garment on the plane, and the plane alone.

    The plane lies :data:`MODEL_DISTANCE_MM` in front of the camera, facing it squarely
    (``T_cam_plane`` a translation along z); the garment lies on it unrotated, its frame's
    origin at ``offset_mm`` in the plane frame (near the image centre). The plane is the
    garment's ``plane_bgr`` (the catalogue's plane-coloured cases), else the station's green.

    Parameters
    ----------
    garment : Garment
    camera : PinholeCamera
        e.g. :func:`model_station_camera`.
    rng : int or Generator, optional
        Seed or generator (plane texture, sensor noise; the two photos' noise is independent).
    noise_sigma : float
        Sensor noise std, grey levels.
    offset_mm : (float, float)
        Garment origin in the plane frame, mm.
    blur_sigma_px : float
        Optical blur, pixels.

    Returns
    -------
    photo_bgr, background_bgr : ndarray (H, W, 3) uint8
    """
    gen = np.random.default_rng(rng)
    T_cam_plane = make_transform(np.eye(3), [0.0, 0.0, MODEL_DISTANCE_MM])
    plane = uniform_plane(MODEL_GREEN_BGR if garment.plane_bgr is None else garment.plane_bgr,
                          rng=gen)
    item = (garment_placement(offset_mm[0], offset_mm[1], 0.0), garment.texture)
    photos = []
    for items in ([item], []):
        image = blur(render_view(camera, T_cam_plane, plane, items), blur_sigma_px)
        photos.append(add_sensor_noise(image, noise_sigma, gen))
    return photos[0], photos[1]


@dataclass(frozen=True)
class StereoScene:
    """One stereo shot of a garment on the table, with its true pose.

    Parameters
    ----------
    right_bgr : ndarray (H, W, 3) uint8
        Camera 1's image (the paper's right camera).
    left_bgr : ndarray (H, W, 3) uint8
        Camera 2's image.
    T_cam1_model : ndarray (4, 4)
        True pose of the garment frame in camera 1's frame, mm.
    """

    right_bgr: NDArray[np.uint8]
    left_bgr: NDArray[np.uint8]
    T_cam1_model: NDArray[np.float64]


def render_stereo_scene(
    garment: Garment,
    rig: StereoRig,
    rng: RngLike = None,
    *,
    x_mm: float,
    y_mm: float,
    theta_deg: float,
    table: PlaneTexture | None = None,
    noise_sigma: float = 2.0,
    blur_sigma_px: float = 0.6,
) -> StereoScene:
    """Render the garment lying on the table (:func:`hand_table_pose`) in both hand cameras.

    Parameters
    ----------
    garment : Garment
    rig : StereoRig
    rng : int or Generator, optional
        Seed or generator (table texture when none is given, sensor noise).
    x_mm, y_mm : float
        Garment origin in the table frame, mm.
    theta_deg : float
        In-plane angle of the garment about the table's z axis, degrees.
    table : PlaneTexture, optional
        Table surface (default: :func:`table_plane` drawn from ``rng``).
    noise_sigma : float
        Sensor noise std, grey levels.
    blur_sigma_px : float
        Optical blur, pixels (applied before the noise).

    Returns
    -------
    StereoScene
        ``T_cam1_model = T_cam1_table @ T_table_garment``.
    """
    gen = np.random.default_rng(rng)
    if table is None:
        table = table_plane(gen)
    T_cam1_table = hand_table_pose(rig)
    T_table_garment = garment_placement(x_mm, y_mm, theta_deg)
    items = [(T_table_garment, garment.texture)]
    images = []
    for camera, T_cam_cam1 in ((rig.cam1, np.eye(4)), (rig.cam2, rig.T_cam2_cam1)):
        image = render_view(camera, T_cam_cam1 @ T_cam1_table, table, items)
        images.append(add_sensor_noise(blur(image, blur_sigma_px), noise_sigma, gen))
    return StereoScene(images[0], images[1], T_cam1_table @ T_table_garment)


def random_stereo_scene(
    garment: Garment,
    rig: StereoRig,
    rng: RngLike = None,
    x_range_mm: tuple[float, float] = (-120.0, 120.0),
    y_range_mm: tuple[float, float] = (-80.0, 80.0),
    theta_range_deg: tuple[float, float] = (-53.0, 53.0),
    **kw: Any,
) -> StereoScene:
    """:func:`render_stereo_scene` at a placement drawn uniformly from the given ranges.

    The default ranges keep garments up to about 200 mm inside both images. Keyword arguments
    ``kw`` go to :func:`render_stereo_scene`.
    """
    gen = np.random.default_rng(rng)
    x_mm = gen.uniform(*x_range_mm)
    y_mm = gen.uniform(*y_range_mm)
    theta_deg = gen.uniform(*theta_range_deg)
    return render_stereo_scene(garment, rig, gen, x_mm=x_mm, y_mm=y_mm, theta_deg=theta_deg, **kw)


@dataclass(frozen=True)
class SimulatedScene:
    """A stereo shot under given conditions, with everything the simulator knows about it.

    Parameters
    ----------
    right_bgr, left_bgr : ndarray (H, W, 3) uint8
        Camera 1's (the paper's right camera) and camera 2's images.
    T_cam1_model : ndarray (4, 4) or None
        True pose of the target garment's frame in camera 1's frame, mm; None without a target.
    info : dict
        JSON-ready facts: placement on the table, tilt, fold height, light, visible fraction of
        the target in each camera, distractors (see :func:`simulate_scene`).
    wrinkles : Wrinkles or None
        The target's cloth surface when it is wrinkled: ``wrinkles.surface_mm(m)`` is where
        material point ``m`` of the garment lies in its frame (``T_cam1_model`` maps it on).
    empty_bgr : (ndarray, ndarray) or None
        Camera 1's and camera 2's images of the same table, light and distractors without
        the target (``simulate_scene(..., empty=True)``), for in-place registration.
    """

    right_bgr: NDArray[np.uint8]
    left_bgr: NDArray[np.uint8]
    T_cam1_model: NDArray[np.float64] | None
    info: dict[str, Any]
    wrinkles: Wrinkles | None = None
    empty_bgr: tuple[NDArray[np.uint8], NDArray[np.uint8]] | None = None


POSITION_RANGE_MM: tuple[float, float] = (510.0, 390.0)
"""The paper's recognition range on the table (x, y), centred under the rig, mm."""

THETA_RANGE_DEG: tuple[float, float] = (-53.0, 53.0)
"""The paper's range of in-plane angles, degrees."""

_MARGIN_PX = 6.0  # the whole target must lie this far inside both images


def _footprint_mm(texture: PlaneTexture, n: int = 64) -> NDArray[np.float64]:
    """About n points (n, 2) of a texture's silhouette outline, in its frame, mm."""
    mask = (texture.alpha > 0.5).astype(np.uint8)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    pts = np.concatenate([c.reshape(-1, 2) for c in contours]).astype(np.float64)
    pts = pts[np.linspace(0, len(pts) - 1, min(n, len(pts))).astype(int)]
    return texture.mm_from_px(pts)


def _radius_mm(texture: PlaneTexture) -> float:
    return float(np.linalg.norm(_footprint_mm(texture), axis=1).max())


def _inside_both(rig: StereoRig, T_cam1_item: NDArray[np.float64],
                 outline_mm: NDArray[np.float64]) -> bool:
    pts = np.column_stack([outline_mm, np.zeros(len(outline_mm))])
    for camera, T in ((rig.cam1, np.eye(4)), (rig.cam2, rig.T_cam2_cam1)):
        p = transform_points(T @ T_cam1_item, pts)
        if np.any(p[:, 2] <= 0):
            return False
        uv = camera.project(p)
        if not (np.all(uv >= _MARGIN_PX) and np.all(uv[:, 0] <= camera.width_px - 1 - _MARGIN_PX)
                and np.all(uv[:, 1] <= camera.height_px - 1 - _MARGIN_PX)):
            return False
    return True


def _tilt(gen: np.random.Generator, tilt_deg: float) -> tuple[NDArray[np.float64], float]:
    if tilt_deg <= 0:
        return np.eye(4), 0.0
    angle = np.radians(gen.uniform(0.0, tilt_deg))
    axis = gen.uniform(0.0, 2.0 * np.pi)
    R = Rotation.from_rotvec(angle * np.array([np.cos(axis), np.sin(axis), 0.0])).as_matrix()
    return make_transform(R, np.zeros(3)), float(np.degrees(angle))


def _foreign_garment(gen: np.random.Generator) -> Garment:
    """A garment that is not in the catalogue: random shape, fabric and size."""
    from photomodel.sim._garments import FABRICS, GARMENT_SHAPES, make_garment

    shape = GARMENT_SHAPES[int(gen.integers(len(GARMENT_SHAPES)))]
    fabric = FABRICS[int(gen.integers(len(FABRICS)))]
    size = (float(gen.uniform(130, 240)), float(gen.uniform(100, 190)))
    return make_garment(shape, fabric, size, rng=gen, mm_per_px=1.0, name=f"other-{shape}")


def _free_spot(gen: np.random.Generator, radius: float, taken: list[tuple[float, float, float]],
               half_range: tuple[float, float]) -> tuple[float, float] | None:
    for _ in range(60):
        x = gen.uniform(-half_range[0], half_range[0])
        y = gen.uniform(-half_range[1], half_range[1])
        if all(np.hypot(x - tx, y - ty) > radius + tr + 5.0 for tx, ty, tr in taken):
            return float(x), float(y)
    return None


def simulate_scene(
    target: Garment | None,
    rig: StereoRig,
    conditions: Conditions | None = None,
    rng: RngLike = None,
    *,
    placement: tuple[float, float, float] | None = None,
    empty: bool = False,
) -> SimulatedScene:
    """Render one stereo shot of the work table under the given conditions.

    The target lies on the table (:func:`hand_table_pose`, tilted by up to
    ``conditions.tilt_deg`` about a random in-plane axis) at a placement drawn uniformly from
    the paper's range (:data:`POSITION_RANGE_MM`, :data:`THETA_RANGE_DEG`) among those that keep
    the whole garment at least 6 px inside both images; with folds when
    ``conditions.wrinkle_height_mm > 0``. Distractors go beside it (never over it), the
    occluder over part of it. The light comes from a random direction 50-80 deg above the table.

    Parameters
    ----------
    target : Garment or None
        The garment to find; must be None when ``conditions.target`` is False.
    rig : StereoRig
        The hand cameras (render with the rig whose calibration is written out).
    conditions : Conditions, optional
        Nuisances (default: the paper's set-up).
    rng : int or Generator, optional
        Seed or generator of everything random in the shot.
    placement : (x_mm, y_mm, theta_deg), optional
        Fixed target placement on the table instead of a random one.
    empty : bool
        Also render the table without the target (``SimulatedScene.empty_bgr``; the random
        stream of the shot itself is the same).

    Returns
    -------
    SimulatedScene
        ``info`` holds ``x_mm``, ``y_mm``, ``theta_deg`` (placement on the table), ``tilt_deg``,
        ``wrinkle_height_mm``, ``light_elevation_deg``, ``light_azimuth_deg``,
        ``visible_fraction`` ([camera 1, camera 2]) and ``distractors`` (kind and position).
    """
    conditions = Conditions() if conditions is None else conditions
    if conditions.target != (target is not None):
        raise ValueError("target: give a garment exactly when conditions.target is True")
    gen = np.random.default_rng(rng)
    table = make_table(conditions.table, gen)
    T_tilt, tilt_deg = _tilt(gen, conditions.tilt_deg)
    T_cam1_table = hand_table_pose(rig) @ T_tilt
    half = (POSITION_RANGE_MM[0] / 2, POSITION_RANGE_MM[1] / 2)
    info: dict[str, Any] = {"tilt_deg": tilt_deg}
    layers_low: list[Layer] = []
    taken: list[tuple[float, float, float]] = []
    target_layer: Layer | None = None
    T_table_garment = None
    wrinkles: Wrinkles | None = None
    if target is not None:
        outline = _footprint_mm(target.texture)
        if placement is None:
            for _ in range(500):
                placement = (gen.uniform(-half[0], half[0]), gen.uniform(-half[1], half[1]),
                             gen.uniform(*THETA_RANGE_DEG))
                if _inside_both(rig, T_cam1_table @ garment_placement(*placement), outline):
                    break
            else:
                raise ValueError(f"target: {target.name} does not fit inside both images")
        x_mm, y_mm, theta_deg = (float(p) for p in placement)
        T_table_garment = garment_placement(x_mm, y_mm, theta_deg)
        if conditions.wrinkle_height_mm > 0:
            wrinkles = make_wrinkles(target.texture, gen, conditions.wrinkle_height_mm)
        target_layer = Layer(target.texture, T_table_garment, wrinkles)
        taken.append((x_mm, y_mm, _radius_mm(target.texture)))
        info.update(x_mm=x_mm, y_mm=y_mm, theta_deg=theta_deg,
                    wrinkle_height_mm=conditions.wrinkle_height_mm)
    distractors: list[dict[str, Any]] = []
    layers_high: list[Layer] = []
    wanted = (["garment"] * conditions.distractor_garments
              + [OBJECT_KINDS[int(gen.integers(len(OBJECT_KINDS)))]
                 for _ in range(conditions.distractor_objects)])
    for kind in wanted:
        if kind == "garment":
            other = _foreign_garment(gen)
            parts, radius = [Layer(other.texture, np.eye(4))], _radius_mm(other.texture)
        else:
            parts = make_object(kind, gen)
            radius = max(_radius_mm(p.texture) for p in parts)
        spot = _free_spot(gen, radius, taken, half)
        if spot is None:
            continue
        angle = float(gen.uniform(-180.0, 180.0))
        placed = place_layers(parts, garment_placement(spot[0], spot[1], angle))
        (layers_low if kind == "garment" else layers_high).extend(placed)
        taken.append((spot[0], spot[1], radius))
        distractors.append({"kind": kind, "x_mm": spot[0], "y_mm": spot[1], "theta_deg": angle})
    info["distractors"] = distractors
    occluders: list[Layer] = []
    if conditions.occlusion != "none" and T_table_garment is not None and target is not None:
        occluders, occluder_info = _occluder(conditions.occlusion, target, T_table_garment, gen)
        info["occluder"] = occluder_info
    items = layers_low + ([target_layer] if target_layer is not None else [])
    track = len(items) - 1 if target_layer is not None else None
    items += layers_high + occluders
    elevation = np.radians(gen.uniform(50.0, 80.0))
    azimuth = gen.uniform(0.0, 2.0 * np.pi)
    light = [np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth),
             -np.sin(elevation)]
    info.update(light_elevation_deg=float(np.degrees(elevation)),
                light_azimuth_deg=float(np.degrees(azimuth)))
    images, fractions = [], []
    for camera, T_cam_cam1 in ((rig.cam1, np.eye(4)), (rig.cam2, rig.T_cam2_cam1)):
        view = render_view_linear(camera, T_cam_cam1 @ T_cam1_table, table, items, track=track,
                                  light_dir_plane=light)
        images.append(expose(view.image, camera, conditions, gen))
        if view.coverage is not None and view.visible is not None:
            fractions.append(float(view.visible.sum() / max(float(view.coverage.sum()), 1e-9)))
    info["visible_fraction"] = fractions if target is not None else None
    T_cam1_model = None if T_table_garment is None else T_cam1_table @ T_table_garment
    empty_bgr = None
    if empty:
        others = [item for item in items if item is not target_layer]
        gen_empty = np.random.default_rng(gen.integers(0, 2**62))
        empty_bgr = tuple(
            expose(render_view_linear(camera, T_cam_cam1 @ T_cam1_table, table, others,
                                      light_dir_plane=light).image, camera, conditions,
                   gen_empty)
            for camera, T_cam_cam1 in ((rig.cam1, np.eye(4)), (rig.cam2, rig.T_cam2_cam1)))
    return SimulatedScene(images[0], images[1], T_cam1_model, info, wrinkles,
                          empty_bgr)  # type: ignore[arg-type]


def _occluder(kind: str, target: Garment, T_table_garment: NDArray[np.float64],
              gen: np.random.Generator) -> tuple[list[Layer], dict[str, Any]]:
    """Layers over part of the target: a gripper 40-120 mm above it, or another garment."""
    radius = _radius_mm(target.texture)
    direction = gen.uniform(-np.pi, np.pi)
    x0, y0 = T_table_garment[0, 3], T_table_garment[1, 3]
    if kind == "gripper":
        layers, finger_mm = gripper(gen)
        reach = gen.uniform(0.1, 0.5) * radius  # fingertips this far past the target's centre
        tip = np.array([x0, y0]) + reach * np.array([np.cos(direction), np.sin(direction)])
        height = float(gen.uniform(40.0, 120.0))
        T = garment_placement(tip[0], tip[1], float(np.degrees(direction)))
        T[2, 3] = -height
        return place_layers(layers, T), {"kind": "gripper", "height_mm": height,
                                         "x_mm": float(tip[0]), "y_mm": float(tip[1])}
    other = _foreign_garment(gen)
    distance = gen.uniform(0.75, 1.1) * (radius + _radius_mm(other.texture)) / 2
    centre = np.array([x0, y0]) + distance * np.array([np.cos(direction), np.sin(direction)])
    angle = float(gen.uniform(-180.0, 180.0))
    T = garment_placement(centre[0], centre[1], angle)
    return [Layer(other.texture, T)], {"kind": "garment", "x_mm": float(centre[0]),
                                       "y_mm": float(centre[1]), "theta_deg": angle}
