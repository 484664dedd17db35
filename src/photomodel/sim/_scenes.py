"""Ready-made synthetic data: model-station photos and stereo scenes with ground truth."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import PinholeCamera, StereoRig
from photomodel.geometry import make_transform
from photomodel.sim._garments import Garment
from photomodel.sim._render import add_sensor_noise, blur, render_view
from photomodel.sim._rigs import MODEL_DISTANCE_MM, hand_table_pose
from photomodel.sim._textures import PlaneTexture, RngLike, table_plane, uniform_plane

__all__ = [
    "StereoScene",
    "garment_placement",
    "random_stereo_scene",
    "render_model_photos",
    "render_stereo_scene",
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
    """The model station's two photos: the garment on the green plane, and the plane alone.

    The plane lies :data:`MODEL_DISTANCE_MM` in front of the camera, facing it squarely
    (``T_cam_plane`` = translation (0, 0, 400)); the garment lies on it unrotated, its frame's
    origin at ``offset_mm`` in the plane frame (near the image centre).

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
    plane = uniform_plane(rng=gen)
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
