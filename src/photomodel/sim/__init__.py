"""Simulator: the paper's cell as a digital twin, writing real-format data with ground truth.

Garments (the catalogue of the paper's 12, or a user's own), the model station and the hand
stereo rig, named nuisances (:data:`CONDITIONS`), an exact renderer for flat items and a mesh
renderer for wrinkled cloth, and :func:`write_dataset` (what ``photomodel simulate`` runs).

Frames follow DESIGN.md: a texture (and garment) frame has x along the texture's columns, y along
its rows and z into the plane; ``T_a_b`` maps frame b to frame a; lengths in mm.
"""

from photomodel.sim._catalogue import (
    CATALOGUE,
    GarmentSpec,
    catalogue_garment,
    garment_from_image,
    garment_names,
    load_garment,
)
from photomodel.sim._conditions import (
    CONDITIONS,
    LENSES,
    TABLES,
    Conditions,
    expose,
    parse_conditions,
    white_balance_gains,
)
from photomodel.sim._dataset import DatasetSummary, scene_rng, write_dataset
from photomodel.sim._garments import (
    FABRICS,
    GARMENT_SHAPES,
    Garment,
    garment_outline_mm,
    make_garment,
)
from photomodel.sim._mesh import Fold, Wrinkles, make_wrinkles, render_mesh_layer
from photomodel.sim._objects import OBJECT_KINDS, gripper, make_object, place_layers
from photomodel.sim._render import (
    Layer,
    RenderedView,
    add_sensor_noise,
    blur,
    pixel_rays,
    render_view,
    render_view_linear,
)
from photomodel.sim._rigs import (
    BASELINE_MM,
    MODEL_DISTANCE_MM,
    WORK_DISTANCE_MM,
    hand_stereo_rig,
    hand_table_pose,
    model_station_camera,
)
from photomodel.sim._scenes import (
    POSITION_RANGE_MM,
    THETA_RANGE_DEG,
    SimulatedScene,
    StereoScene,
    garment_placement,
    random_stereo_scene,
    render_model_photos,
    render_stereo_scene,
    simulate_scene,
)
from photomodel.sim._sheet import contact_sheet
from photomodel.sim._tables import make_table
from photomodel.sim._textures import (
    MODEL_GREEN_BGR,
    PHOTO_PRINTS,
    PLAID_HUES,
    PLAIN_HUES,
    TABLE_GREY_BGR,
    PlaneTexture,
    RngLike,
    camo_fabric,
    dot_fabric,
    garment_hues,
    hsv_to_bgr,
    photo_fabric,
    photo_print_image,
    plaid_fabric,
    plain_fabric,
    print_fabric,
    stripe_fabric,
    table_plane,
    uniform_plane,
)

__all__ = [
    "BASELINE_MM",
    "CATALOGUE",
    "CONDITIONS",
    "FABRICS",
    "GARMENT_SHAPES",
    "LENSES",
    "MODEL_DISTANCE_MM",
    "MODEL_GREEN_BGR",
    "OBJECT_KINDS",
    "PHOTO_PRINTS",
    "PLAID_HUES",
    "PLAIN_HUES",
    "POSITION_RANGE_MM",
    "TABLES",
    "TABLE_GREY_BGR",
    "THETA_RANGE_DEG",
    "WORK_DISTANCE_MM",
    "Conditions",
    "DatasetSummary",
    "Fold",
    "Garment",
    "GarmentSpec",
    "Layer",
    "PlaneTexture",
    "RenderedView",
    "RngLike",
    "SimulatedScene",
    "StereoScene",
    "Wrinkles",
    "add_sensor_noise",
    "blur",
    "camo_fabric",
    "catalogue_garment",
    "contact_sheet",
    "dot_fabric",
    "expose",
    "garment_from_image",
    "garment_hues",
    "garment_names",
    "garment_outline_mm",
    "garment_placement",
    "gripper",
    "hand_stereo_rig",
    "hand_table_pose",
    "hsv_to_bgr",
    "load_garment",
    "make_garment",
    "make_object",
    "make_table",
    "make_wrinkles",
    "model_station_camera",
    "parse_conditions",
    "photo_fabric",
    "photo_print_image",
    "pixel_rays",
    "place_layers",
    "plaid_fabric",
    "plain_fabric",
    "print_fabric",
    "random_stereo_scene",
    "render_mesh_layer",
    "render_model_photos",
    "render_stereo_scene",
    "render_view",
    "render_view_linear",
    "scene_rng",
    "simulate_scene",
    "stripe_fabric",
    "table_plane",
    "uniform_plane",
    "white_balance_gains",
    "write_dataset",
]
