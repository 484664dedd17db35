"""The paper's fitness, eq. (9), with its voting rule as read here.

How the paper's rule is read (sec. 2.4: "+2 for every point of clothes in captured images that
lies inside of the model frame S_in, -0.005 for every point of clothes in images that lies in
the background area S_out, and otherwise 0"):

* Each model point is projected into each camera with the candidate pose (eqs. 1-8, with the
  cameras' distortion) and looked up at the nearest pixel.
* An S_in point votes ``p = +2`` when the image's colour there *matches the point's own hue*
  (the photo-model's colour at that point), else 0: a garment point inside the model frame.
* An S_out point votes ``p = 0.005``, subtracted, when the image there shows *the garment*: its
  colour matches the hue of the nearest S_in point (the garment's colour just inside the
  outline). So a model that is too small, or shifted, pays for the garment it leaves outside.
* Points that fall outside an image vote 0.
* The hue match (:class:`HueMatch`): both colours have a hue and they differ by at most
  ``hue_threshold_deg`` (20 deg), or neither has a hue (saturation or value too low).
* ``F = (F_R + F_L) / 2`` with ``F_c = sum_in p - sum_out p`` for camera c; the score is
  ``F / (2 N_in)``, 1 when every S_in point matches in both images and no S_out point does.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from photomodel.camera import StereoRig
from photomodel.fitness._hue import HueMatch, hue_code_image, hue_codes, hue_codes_match
from photomodel.geometry import pose_vectors_to_matrices
from photomodel.model import PhotoModel

__all__ = ["FITNESS_PRESETS", "PaperFitness", "PaperVotes", "make_fitness"]

Backend = Literal["numba", "numpy"]


@dataclass(frozen=True)
class PaperVotes:
    """Votes of eq. (9): +``inside`` per matching S_in point, -``outside`` per S_out point.

    With ``balance_outside`` the outside vote is multiplied by ``N_in / N_out``, so that the
    band as a whole weighs as much as the inside (the ``balanced`` fitness).
    """

    inside: float = 2.0
    outside: float = 0.005
    balance_outside: bool = False


FITNESS_PRESETS: dict[str, tuple[PaperVotes, HueMatch]] = {
    # The paper's rule as read here (module docstring): hue alone.
    "paper": (PaperVotes(2.0, 0.005), HueMatch()),
    # Eq. (9) with inner and outer terms of equal total weight: a model shrunk, shifted or
    # pushed away so that part of its band lies on the garment loses as much as one whose
    # inside leaves the garment. With the paper's 400:1 ratio a plain garment's model can be
    # shrunk (z too large) at almost no cost. The hue match also asks for half the model
    # point's saturation, which puts blurred edges where they are (see HueMatch).
    "balanced": (PaperVotes(1.0, 1.0, balance_outside=True), HueMatch(relative_saturation=0.5)),
}


class PaperFitness:
    """Eq. (9) for a photo-model and one stereo pair, evaluated on whole populations.

    Parameters
    ----------
    model : PhotoModel
    rig : StereoRig
    right_bgr, left_bgr : ndarray (H, W, 3) uint8
        Camera 1 (the paper's right camera) and camera 2 images.
    match : HueMatch, optional
    votes : PaperVotes, optional
    backend : {"numba", "numpy"}
        The compiled kernel (default) or the numpy reference implementation.
    """

    def __init__(self, model: PhotoModel, rig: StereoRig, right_bgr: NDArray[np.uint8],
                 left_bgr: NDArray[np.uint8], *, match: HueMatch | None = None,
                 votes: PaperVotes | None = None, backend: Backend = "numba",
                 name: str = "paper") -> None:
        self.name = name
        self.match = match or HueMatch()
        self.votes = votes or FITNESS_PRESETS["paper"][0]
        if backend not in ("numba", "numpy"):
            raise ValueError(f"backend: expected 'numba' or 'numpy', got {backend!r}")
        self.backend = backend
        self.model = model
        self.rig = rig
        self.images = (hue_code_image(right_bgr, self.match), hue_code_image(left_bgr, self.match))
        self.p_in = np.ascontiguousarray(model.points_in_mm, dtype=np.float64)
        self.c_in = hue_codes(model.hsv_in, self.match)
        self.s_in = (self.match.relative_saturation * model.hsv_in[:, 1]).astype(np.float64)
        self.p_out = np.ascontiguousarray(model.points_out_mm, dtype=np.float64)
        nearest = np.zeros(0, dtype=np.int64)
        if model.n_out:
            _, nearest = cKDTree(model.points_in_mm[:, :2]).query(model.points_out_mm[:, :2])
        self.c_out = np.ascontiguousarray(self.c_in[nearest])
        self.s_out = np.ascontiguousarray(self.s_in[nearest])
        self.last_counts: NDArray[np.int64] = np.zeros((0, 4), dtype=np.int64)
        self._vote_out = self.votes.outside
        if self.votes.balance_outside and model.n_out:
            self._vote_out *= model.n_in / model.n_out

    @property
    def max_fitness(self) -> float:
        """Fitness when all S_in points match in both images and no S_out point does."""
        return self.votes.inside * self.model.n_in

    def score(self, fitness: float) -> float:
        """``fitness / max_fitness`` clipped to [0, 1]."""
        return float(np.clip(fitness / self.max_fitness, 0.0, 1.0))

    def __call__(self, poses: NDArray[np.float64]) -> NDArray[np.float64]:
        """Fitness (P,) of pose vectors (P, 6) = (x, y, z mm, eps1, eps2, eps3)."""
        return self.evaluate_transforms(pose_vectors_to_matrices(poses))

    def evaluate_transforms(self, T_cam1_model: NDArray[np.float64]) -> NDArray[np.float64]:
        """Fitness (P,) of candidate transforms ``T_cam1_model`` (P, 4, 4).

        The match counts of the last call are kept in ``last_counts`` (P, 4): S_in and S_out
        matches in camera 1, then in camera 2.
        """
        T = np.ascontiguousarray(np.asarray(T_cam1_model, dtype=np.float64).reshape(-1, 4, 4))
        if self.backend == "numba":
            f, counts = self._numba(T)
        else:
            f, counts = self._numpy(T)
        self.last_counts = counts
        return f

    def _numba(self, T: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        from photomodel.fitness._kernels import paper_fitness_kernel

        c1, c2 = self.rig.cameras
        f = np.empty(len(T))
        counts = np.empty((len(T), 4), dtype=np.int64)
        paper_fitness_kernel(
            np.ascontiguousarray(T[:, :3, :3]), np.ascontiguousarray(T[:, :3, 3]),
            self.rig.R, self.rig.T, c1.K, c1.distortion12, c2.K, c2.distortion12,
            self.p_in, self.c_in.astype(np.float64), self.s_in,
            self.p_out, self.c_out.astype(np.float64), self.s_out,
            *self.images[0], *self.images[1], float(self.match.hue_threshold_deg),
            float(self.votes.inside), float(self._vote_out), f, counts)
        return f, counts

    def _numpy(self, T: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        counts = np.zeros((len(T), 4), dtype=np.int64)
        sets = ((self.p_in, self.c_in, self.s_in), (self.p_out, self.c_out, self.s_out))
        for k, (pts, codes, min_sat) in enumerate(sets):
            if len(pts) == 0:
                continue
            uv1, uv2 = self.rig.project_poses(T, pts)
            for cam, (uv, img) in enumerate(zip((uv1, uv2), self.images, strict=True)):
                counts[:, 2 * cam + k] = self._count(uv, codes, min_sat, img)
        vi, vo = self.votes.inside, self._vote_out
        right = vi * counts[:, 0] - vo * counts[:, 1]
        left = vi * counts[:, 2] - vo * counts[:, 3]
        f = (right + left) / 2.0
        return f, counts

    def _count(self, uv: NDArray[np.float64], codes: NDArray[np.float32],
               min_sat: NDArray[np.float64],
               img: tuple[NDArray[np.float32], NDArray[np.float32]]) -> NDArray[np.int64]:
        codes_img, sat_img = img
        h, w = codes_img.shape
        with np.errstate(invalid="ignore"):
            iu = np.floor(np.nan_to_num(uv[..., 0], nan=-1e9) + 0.5)
            iv = np.floor(np.nan_to_num(uv[..., 1], nan=-1e9) + 0.5)
        inside = (iu >= 0) & (iv >= 0) & (iu < w) & (iv < h)
        pix = np.full(iu.shape, np.nan, dtype=np.float64)
        sat = np.zeros(iu.shape, dtype=np.float64)
        rows, cols = iv[inside].astype(np.int64), iu[inside].astype(np.int64)
        pix[inside] = codes_img[rows, cols]
        sat[inside] = sat_img[rows, cols]
        ok = inside & hue_codes_match(pix, np.broadcast_to(codes, iu.shape),
                                      self.match.hue_threshold_deg, sat,
                                      np.broadcast_to(min_sat, iu.shape))
        return ok.sum(axis=1)


def make_fitness(name: str, model: PhotoModel, rig: StereoRig, right_bgr: NDArray[np.uint8],
                 left_bgr: NDArray[np.uint8], **kw: object) -> PaperFitness:
    """The named fitness (a key of ``FITNESS_PRESETS``) for one model and stereo pair."""
    if name not in FITNESS_PRESETS:
        raise ValueError(f"fitness: expected one of {sorted(FITNESS_PRESETS)}, got {name!r}")
    votes, match = FITNESS_PRESETS[name]
    return PaperFitness(model, rig, right_bgr, left_bgr, votes=votes, match=match, name=name,
                        **kw)  # type: ignore[arg-type]
