"""Named, seeded nuisances of a simulated shot, and the camera's response to the light.

A :class:`Conditions` holds every nuisance as a field; :data:`CONDITIONS` names presets, and
:func:`parse_conditions` joins names with ``+`` (``"wood+wrinkles+dim"``: later names override
earlier ones field by field, starting from ``"paper"``, the seed paper's set-up). The random parts
(where the garment lies, which folds it has, where a distractor goes, the sensor noise) are drawn
from the ``rng`` of the scene, so a seed fixes every image.

Light and sensor model (:func:`expose`): the renderer's colours are sRGB-encoded reflectances under
a white (6500 K) light. They are decoded to linear light, multiplied by the light level, by the
illuminant's colour relative to the camera's fixed daylight white balance (Planckian locus, Kim et
al. 2002 cubic approximation, to CIE xy, to linear sRGB) and by the lens's vignetting
(``1 - v r^2``, ``r`` = distance from the principal point over its largest value), encoded
again, blurred (optics), given Gaussian sensor noise and quantised to 8 bits with clipping.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import cv2
import numba
import numpy as np
from numpy.typing import NDArray

from photomodel._jit import njit
from photomodel.camera import PinholeCamera
from photomodel.sim._presets import CONDITIONS
from photomodel.sim._textures import RngLike

__all__ = [
    "CONDITIONS",
    "LENSES",
    "TABLES",
    "Conditions",
    "expose",
    "parse_conditions",
    "white_balance_gains",
]

TABLES: tuple[str, ...] = ("grey", "wood", "conveyor", "green")
"""Table surfaces the hand cameras can look at."""

LENSES: tuple[str, ...] = ("standard", "none", "wide")
"""Lens distortion of the hand cameras: k1 about -0.15, none, or a wide-angle k1 about -0.32."""

OCCLUSIONS: tuple[str, ...] = ("none", "gripper", "garment")


@dataclass(frozen=True)
class Conditions:
    """Every nuisance of a simulated stereo shot (defaults: the paper's set-up).

    Parameters
    ----------
    light_level : float
        Scene brightness relative to a correctly exposed image (0.4 = dim, 1.6 = over-exposed).
    colour_temperature_k : float
        Colour temperature of the light, K; the cameras keep a fixed 6500 K white balance, so
        3000 K makes a warm (orange) cast and 10000 K a cool (blue) one.
    vignetting : float
        Relative loss of light at the farthest image corner (0 = none).
    noise_sigma : float
        Sensor noise std, grey levels.
    blur_sigma_px : float
        Optical blur std, pixels.
    lens : str
        Hand cameras' distortion, one of :data:`LENSES`. A property of the rig, so one value per
        dataset (its ``stereo.yaml``).
    table : str
        Table surface, one of :data:`TABLES`.
    tilt_deg : float
        Largest tilt of the table (and the garment on it) away from facing the rig, degrees.
    wrinkle_height_mm : float
        Largest fold height of the garment's cloth, mm (0 = flat).
    distractor_garments : int
        Other garments (not in the catalogue) lying beside the target.
    distractor_objects : int
        Other objects (boxes, trays, tape) beside the target.
    occlusion : str
        ``"none"``, ``"gripper"`` (a gripper above the garment hides part of it) or
        ``"garment"`` (another garment lies over part of it).
    target : bool
        False for a scene with no catalogue garment at all.
    """

    light_level: float = 1.0
    colour_temperature_k: float = 6500.0
    vignetting: float = 0.08
    noise_sigma: float = 2.0
    blur_sigma_px: float = 0.6
    lens: str = "standard"
    table: str = "grey"
    tilt_deg: float = 0.0
    wrinkle_height_mm: float = 0.0
    distractor_garments: int = 0
    distractor_objects: int = 0
    occlusion: str = "none"
    target: bool = True

    def __post_init__(self) -> None:
        if not self.light_level > 0:
            raise ValueError(f"light_level: must be positive, got {self.light_level}")
        if not 1000.0 <= self.colour_temperature_k <= 25000.0:
            raise ValueError("colour_temperature_k: expected 1000-25000 K, got "
                             f"{self.colour_temperature_k}")
        if not 0.0 <= self.vignetting < 1.0:
            raise ValueError(f"vignetting: expected [0, 1), got {self.vignetting}")
        for name in ("noise_sigma", "blur_sigma_px", "tilt_deg", "wrinkle_height_mm"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name}: must be >= 0, got {getattr(self, name)}")
        for name, allowed in (("lens", LENSES), ("table", TABLES), ("occlusion", OCCLUSIONS)):
            if getattr(self, name) not in allowed:
                raise ValueError(f"{name}: expected one of {allowed}, got {getattr(self, name)!r}")
        if self.distractor_garments < 0 or self.distractor_objects < 0:
            raise ValueError("distractor counts must be >= 0")
        if not self.target and self.occlusion != "none":
            raise ValueError("occlusion needs a target garment")





def parse_conditions(spec: str) -> Conditions:
    """Conditions of a name like ``"wood+wrinkles"`` (``+``-joined :data:`CONDITIONS` names).

    Raises
    ------
    ValueError
        Unknown name, naming the known ones.
    """
    fields: dict[str, object] = {}
    for name in spec.split("+"):
        name = name.strip()
        if name not in CONDITIONS:
            raise ValueError(f"unknown condition {name!r}; known: {', '.join(CONDITIONS)}")
        fields.update(CONDITIONS[name])
    return dataclasses.replace(Conditions(), **fields)  # type: ignore[arg-type]


def _planckian_xy(temperature_k: float) -> tuple[float, float]:
    """CIE 1931 xy of a black body (Kim et al. 2002 cubic fit, 1667-25000 K)."""
    t = float(temperature_k)
    if t <= 4000.0:
        x = -0.2661239e9 / t**3 - 0.2343589e6 / t**2 + 0.8776956e3 / t + 0.179910
    else:
        x = -3.0258469e9 / t**3 + 2.1070379e6 / t**2 + 0.2226347e3 / t + 0.240390
    if t <= 2222.0:
        y = -1.1063814 * x**3 - 1.34811020 * x**2 + 2.18555832 * x - 0.20219683
    elif t <= 4000.0:
        y = -0.9549476 * x**3 - 1.37418593 * x**2 + 2.09137015 * x - 0.16748867
    else:
        y = 3.0817580 * x**3 - 5.87338670 * x**2 + 3.75112997 * x - 0.37001483
    return x, y


_XYZ_TO_LINEAR_SRGB = np.array([[3.2404542, -1.5371385, -0.4985314],
                                [-0.9692660, 1.8760108, 0.0415560],
                                [0.0556434, -0.2040259, 1.0572252]])


def _linear_rgb_of_light(temperature_k: float) -> NDArray[np.float64]:
    x, y = _planckian_xy(temperature_k)
    xyz = np.array([x / y, 1.0, (1.0 - x - y) / y])
    return _XYZ_TO_LINEAR_SRGB @ xyz


def white_balance_gains(temperature_k: float, reference_k: float = 6500.0
                        ) -> NDArray[np.float64]:
    """Linear (B, G, R) gains (3,) a light of ``temperature_k`` gives a camera balanced for
    ``reference_k``, normalised to green = 1."""
    rgb = _linear_rgb_of_light(temperature_k) / _linear_rgb_of_light(reference_k)
    return (rgb / rgb[1])[::-1]


_DECODE_STEPS = 16  # decode table entries per grey level
_DECODE_MAX = 512.0  # rendered values up to here (shading may exceed 255)
_ENCODE_SIZE = 8192  # encode table entries over linear [0, 1]


def _srgb_decode(v: NDArray[np.float64]) -> NDArray[np.float64]:
    v = np.clip(v, 0.0, None)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def _srgb_encode(v: NDArray[np.float64]) -> NDArray[np.float64]:
    v = np.clip(v, 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)


# sRGB transfer functions tabulated finely enough that linear interpolation between entries is
# exact to far below one grey level (checked by the tests against the formulas).
_DECODE_LUT = _srgb_decode(np.arange(int(_DECODE_MAX * _DECODE_STEPS) + 2) / _DECODE_STEPS
                           / 255.0).astype(np.float32)
_ENCODE_LUT = (255.0 * _srgb_encode(np.arange(_ENCODE_SIZE + 2) / _ENCODE_SIZE)).astype(
    np.float32)


@njit(parallel=True)
def _relight(image: NDArray[np.float32], gain_bgr: NDArray[np.float32],
             vignette: NDArray[np.float32], decode: NDArray[np.float32],
             encode: NDArray[np.float32]) -> NDArray[np.float32]:  # pragma: no cover
    """sRGB-decode, scale by gain and vignetting, sRGB-encode (clipped to 0-255), per pixel."""
    height, width = image.shape[0], image.shape[1]
    out = np.empty_like(image)
    top = decode.shape[0] - 2
    for i in numba.prange(height):
        for j in range(width):
            for c in range(3):
                x = min(max(image[i, j, c], 0.0) * _DECODE_STEPS, top)
                k = int(x)
                f = x - k
                lin = (1.0 - f) * decode[k] + f * decode[k + 1]
                y = min(lin * gain_bgr[c] * vignette[i, j], 1.0) * _ENCODE_SIZE
                k = int(y)
                f = y - k
                out[i, j, c] = (1.0 - f) * encode[k] + f * encode[k + 1]
    return out


def _vignette(camera: PinholeCamera, strength: float,
              shape: tuple[int, int]) -> NDArray[np.float32]:
    h, w = shape
    if strength == 0:
        return np.ones((h, w), np.float32)
    cx, cy = camera.K[0, 2], camera.K[1, 2]
    v, u = np.mgrid[0:h, 0:w]
    r2 = (u - cx) ** 2 + (v - cy) ** 2
    corners = [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)]
    r2_max = max((x - cx) ** 2 + (y - cy) ** 2 for x, y in corners)
    return (1.0 - strength * r2 / r2_max).astype(np.float32)


def expose(
    image: NDArray[np.floating],
    camera: PinholeCamera,
    conditions: Conditions,
    rng: RngLike = None,
) -> NDArray[np.uint8]:
    """Turn a rendered image into what the camera records under the given conditions.

    Parameters
    ----------
    image : ndarray (H, W, 3) float
        Rendered BGR colours (sRGB-encoded, 0-255 scale, under white light).
    camera : PinholeCamera
        The camera (its principal point centres the vignetting).
    conditions : Conditions
        Light level, colour temperature, vignetting, blur and noise.
    rng : int or Generator, optional
        Seed or generator of the sensor noise.

    Returns
    -------
    ndarray (H, W, 3) uint8
    """
    gen = np.random.default_rng(rng)
    image = np.ascontiguousarray(image, dtype=np.float32)
    if image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"image: expected (H, W, 3), got {image.shape}")
    gain = conditions.light_level * white_balance_gains(conditions.colour_temperature_k)
    encoded = _relight(image, gain.astype(np.float32),
                       _vignette(camera, conditions.vignetting, image.shape[:2]), _DECODE_LUT,
                       _ENCODE_LUT)
    if conditions.blur_sigma_px > 0:
        encoded = cv2.GaussianBlur(encoded, (0, 0), conditions.blur_sigma_px)
    if conditions.noise_sigma > 0:
        noise = gen.standard_normal(encoded.shape, dtype=np.float32)
        encoded += np.float32(conditions.noise_sigma) * noise
    return np.clip(np.rint(encoded), 0, 255).astype(np.uint8)
