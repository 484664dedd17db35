"""Things that are not the target garment: boxes, trays, tape and a gripper.

Each maker returns a list of :class:`Layer` in its own object frame (z into the table, origin on
the table under the object's middle); :func:`place_layers` puts them on the table. Solid objects
are built from flat faces: a box is its top, lifted by its height, and four sides that are culled
when they face away from the camera, so each camera sees the faces it should (parallax included).
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

from photomodel.geometry import make_transform
from photomodel.sim._render import Layer
from photomodel.sim._textures import PlaneTexture, RngLike, hsv_to_bgr

__all__ = ["OBJECT_KINDS", "gripper", "make_object", "place_layers"]

OBJECT_KINDS: tuple[str, ...] = ("box", "tray", "tape")

_MM_PER_PX = 1.0


def _texture(image: NDArray[np.floating], alpha: NDArray[np.floating],
             mm_per_px: float = _MM_PER_PX) -> PlaneTexture:
    h, w = alpha.shape
    return PlaneTexture(np.clip(np.rint(image), 0, 255).astype(np.uint8),
                        np.clip(alpha, 0, 1).astype(np.float32), mm_per_px,
                        np.array([(w - 1) / 2.0, (h - 1) / 2.0]))


def _grain(shape: tuple[int, int], gen: np.random.Generator, sigma: float) -> NDArray[np.float32]:
    return gen.normal(0.0, sigma, shape).astype(np.float32)[..., None]


def _rect_face(w_mm: float, h_mm: float, colour_bgr: NDArray[np.float64],
               gen: np.random.Generator) -> PlaneTexture:
    w, h = max(2, round(w_mm / _MM_PER_PX)), max(2, round(h_mm / _MM_PER_PX))
    image = np.asarray(colour_bgr, np.float32)[None, None, :] + _grain((h, w), gen, 3.0)
    return _texture(image, np.ones((h, w)))


def _rot_z(angle: float) -> NDArray[np.float64]:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _box(gen: np.random.Generator) -> list[Layer]:
    """A closed cardboard box: brown faces, a strip of tape and a shipping label on top."""
    w, d, h = gen.uniform(110, 190), gen.uniform(80, 140), gen.uniform(40, 90)
    brown = hsv_to_bgr([gen.uniform(11, 16), gen.uniform(110, 150), gen.uniform(150, 190)])[0]
    top = _rect_face(w, d, brown, gen)
    image = top.image_bgr.astype(np.float32)
    tape_half = round(gen.uniform(20, 28) / 2 / _MM_PER_PX)
    mid = image.shape[0] // 2
    image[mid - tape_half:mid + tape_half] = 0.75 * image[mid - tape_half:mid + tape_half] + 50
    lw, lh = round(0.35 * image.shape[1]), round(0.3 * image.shape[0])
    image[4:4 + lh, 4:4 + lw] = 238.0
    for row in range(8, lh - 2, 5):  # lines of print on the label
        image[row:row + 2, 8:8 + int(gen.uniform(0.4, 0.9) * (lw - 12))] = 40.0
    layers = []
    # Sides: texture frame x along the box edge, y down the side, -z facing outwards.
    for angle, length, offset in ((0.0, w, d / 2), (np.pi / 2, d, w / 2),
                                  (np.pi, w, d / 2), (-np.pi / 2, d, w / 2)):
        face = _rect_face(length, h, brown * 0.92, gen)
        # Face frame (angle 0, the side at -y): x = -x_object, y = down = +z_object,
        # z = +y_object (into the box).
        R = _rot_z(angle) @ np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
        centre = _rot_z(angle) @ np.array([0.0, -offset, -h / 2])
        layers.append(Layer(face, make_transform(R, centre), cull_back=True))
    layers.append(Layer(_texture(image, np.ones(image.shape[:2])),
                        make_transform(np.eye(3), [0.0, 0.0, -h])))
    return layers


def _rounded_alpha(w: int, h: int, radius: int) -> NDArray[np.float32]:
    alpha = np.zeros((h * 4, w * 4), np.float32)
    r = radius * 4
    cv2.rectangle(alpha, (r, 0), (w * 4 - 1 - r, h * 4 - 1), 1.0, -1)
    cv2.rectangle(alpha, (0, r), (w * 4 - 1, h * 4 - 1 - r), 1.0, -1)
    for cx, cy in ((r, r), (w * 4 - 1 - r, r), (r, h * 4 - 1 - r), (w * 4 - 1 - r, h * 4 - 1 - r)):
        cv2.circle(alpha, (cx, cy), r, 1.0, -1)
    return cv2.resize(alpha, (w, h), interpolation=cv2.INTER_AREA)


def _tray(gen: np.random.Generator) -> list[Layer]:
    """A shallow plastic tray (blue, grey or black), its floor darker than its rim."""
    w, h = round(gen.uniform(180, 260)), round(gen.uniform(130, 180))
    hsv = [[gen.uniform(100, 115), gen.uniform(120, 220), gen.uniform(110, 190)],
           [0.0, 0.0, gen.uniform(90, 150)], [0.0, 0.0, gen.uniform(35, 55)]][gen.integers(3)]
    colour = hsv_to_bgr(hsv)[0]
    alpha = _rounded_alpha(w, h, 14)
    inner = np.zeros_like(alpha)
    inner[12:-12, 12:-12] = _rounded_alpha(w - 24, h - 24, 8)
    image = colour[None, None, :] * (1.0 - 0.18 * inner[..., None]) + _grain((h, w), gen, 2.5)
    return [Layer(_texture(image, alpha), np.eye(4))]


def _tape(gen: np.random.Generator) -> list[Layer]:
    """A roll of packing tape lying flat: its top face, about 50 mm above the table."""
    outer = gen.uniform(45, 55)
    size = round(2 * outer / _MM_PER_PX) + 4
    yy, xx = np.mgrid[0:size, 0:size]
    r = np.hypot(xx - (size - 1) / 2, yy - (size - 1) / 2) * _MM_PER_PX
    alpha = np.clip(outer - r + 0.5, 0, 1) * np.clip(r - 0.75 * outer + 0.5, 0, 1)
    colour = hsv_to_bgr([gen.uniform(12, 20), gen.uniform(90, 160), gen.uniform(150, 200)])[0]
    bands = 1.0 - 0.08 * (np.sin(r * 1.7) > 0)
    image = colour[None, None, :] * bands[..., None] + _grain((size, size), gen, 2.0)
    return [Layer(_texture(image, alpha), make_transform(np.eye(3), [0.0, 0.0, -48.0]))]


def make_object(kind: str, rng: RngLike = None) -> list[Layer]:
    """Layers of an object of the given kind (:data:`OBJECT_KINDS`) in its own frame."""
    gen = np.random.default_rng(rng)
    if kind == "box":
        return _box(gen)
    if kind == "tray":
        return _tray(gen)
    if kind == "tape":
        return _tape(gen)
    raise ValueError(f"kind: expected one of {OBJECT_KINDS}, got {kind!r}")


def gripper(rng: RngLike = None) -> tuple[list[Layer], float]:
    """A parallel gripper seen from above: an arm, a palm and two fingers, all dark metal.

    Its frame's origin is the middle between the fingertips, the arm along -x. Returns the
    layers (at height 0: :func:`place_layers` lifts them) and the length of the fingers, mm.
    """
    gen = np.random.default_rng(rng)
    finger_mm, gap_mm, arm_mm = gen.uniform(50, 70), gen.uniform(50, 90), 420.0
    w = round((arm_mm + 40 + finger_mm) / _MM_PER_PX)
    h = round((gap_mm + 60) / _MM_PER_PX)
    alpha = np.zeros((h, w), np.float32)
    cx, cy = w - 1 - finger_mm / _MM_PER_PX, (h - 1) / 2
    arm_half = 24 / _MM_PER_PX
    cv2.rectangle(alpha, (0, round(cy - arm_half)), (round(cx - 40), round(cy + arm_half)), 1, -1)
    cv2.rectangle(alpha, (round(cx - 40), 0), (round(cx), h - 1), 1, -1)  # palm
    for sign in (-1, 1):
        y0 = cy + sign * (gap_mm / 2 + 6) / _MM_PER_PX
        cv2.rectangle(alpha, (round(cx), round(y0 - 6)), (w - 1, round(y0 + 6)), 1, -1)
    alpha = cv2.GaussianBlur(alpha, (0, 0), 0.6)
    level = gen.uniform(70, 100)
    image = np.full((h, w, 3), level, np.float32)
    image[round(cy - 4):round(cy + 4), :round(cx - 40)] += 60  # a highlight along the arm
    image += _grain((h, w), gen, 3.0)
    texture = PlaneTexture(np.clip(np.rint(image), 0, 255).astype(np.uint8), alpha, _MM_PER_PX,
                           np.array([w - 1.0, cy]))
    return [Layer(texture, np.eye(4))], finger_mm


def place_layers(layers: list[Layer], T_table_object: NDArray[np.float64]) -> list[Layer]:
    """The layers moved by ``T_table_object`` (their poses composed with it)."""
    return [Layer(layer.texture, T_table_object @ layer.T_plane_item, layer.wrinkles,
                  layer.cull_back) for layer in layers]
