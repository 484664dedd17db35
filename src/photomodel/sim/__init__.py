"""Simulator: exact renderer of flat garments on a plane, default rigs, synthetic scenes.

Frames follow DESIGN.md: a texture (and garment) frame has x along the texture's columns, y along
its rows and z into the plane; ``T_a_b`` maps frame b to frame a; lengths in mm.
"""

from photomodel.sim._garments import (
    FABRICS,
    GARMENT_SHAPES,
    Garment,
    garment_outline_mm,
    make_garment,
)
from photomodel.sim._render import add_sensor_noise, blur, pixel_rays, render_view
from photomodel.sim._rigs import (
    BASELINE_MM,
    MODEL_DISTANCE_MM,
    WORK_DISTANCE_MM,
    hand_stereo_rig,
    hand_table_pose,
    model_station_camera,
)
from photomodel.sim._scenes import (
    StereoScene,
    garment_placement,
    random_stereo_scene,
    render_model_photos,
    render_stereo_scene,
)
from photomodel.sim._textures import (
    MODEL_GREEN_BGR,
    PLAID_HUES,
    PLAIN_HUES,
    TABLE_GREY_BGR,
    PlaneTexture,
    RngLike,
    garment_hues,
    hsv_to_bgr,
    plaid_fabric,
    plain_fabric,
    table_plane,
    uniform_plane,
)

__all__ = [
    "BASELINE_MM",
    "FABRICS",
    "GARMENT_SHAPES",
    "MODEL_DISTANCE_MM",
    "MODEL_GREEN_BGR",
    "PLAID_HUES",
    "PLAIN_HUES",
    "TABLE_GREY_BGR",
    "WORK_DISTANCE_MM",
    "Garment",
    "PlaneTexture",
    "RngLike",
    "StereoScene",
    "add_sensor_noise",
    "blur",
    "garment_hues",
    "garment_outline_mm",
    "garment_placement",
    "hand_stereo_rig",
    "hand_table_pose",
    "hsv_to_bgr",
    "make_garment",
    "model_station_camera",
    "pixel_rays",
    "plaid_fabric",
    "plain_fabric",
    "random_stereo_scene",
    "render_model_photos",
    "render_stereo_scene",
    "render_view",
    "table_plane",
    "uniform_plane",
]
