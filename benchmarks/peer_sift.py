"""The feature-matching peer of ``locate`` for the benchmark (not part of the product).

A textbook planar-object pose estimator, as a vision engineer would build it from OpenCV:

1. **Model features** (once per photo-model, cached by the caller; not timed): SIFT keypoints
   and descriptors of the model photo inside the garment mask. Keypoint pixels of the crop
   become full-photo pixels (+ ``crop_origin_px``) and are back-projected onto the garment
   plane exactly as the model build does (``to_model`` in ``photomodel/model/_build.py``):
   ``xy = undistort(uv) * distance_mm - centroid``, ``z = 0``, model frame, mm.
2. **Scene features** (timed): SIFT on the whole grey image of each camera, once per image.
3. **Matching** (timed): brute-force L2 k-nearest-neighbour matching of the scene descriptors
   against the model's, Lowe's ratio test, then one scene keypoint per model point (the
   closest), in both cameras.
4. **Initial pose** (timed): ``cv2.solvePnPRansac`` on camera 1's matches (camera 1's K and
   distortion); when camera 1 yields too few inliers (garment out of its view), the same on
   camera 2, moved into camera 1 through the rig (``T_cam1_model = T_cam2_cam1^-1 T_cam2_model``).
5. **Joint refinement** (timed): ``scipy.optimize.least_squares`` with a robust loss over the
   6-DoF pose (rotation vector, translation of ``T_cam1_model``), minimising the reprojection
   error of the matches of both cameras (camera 2 through ``X2 = R X1 + T``) with
   ``cv2.projectPoints`` (OpenCV's distortion model, the product's too). Matches within
   ``gate_px`` of the initial pose take part; after a first solve the inliers are re-gated at
   ``inlier_px`` and the solve repeated once.

It fails cleanly (``ok=False`` and a ``reason``) when the model has too few keypoints (plain
fabric; the scene images are still processed, so the time is that of a stereo pair), too few
matches survive the ratio test, RANSAC finds too few inliers, or the pose is implausible (model
behind the camera or seen from behind).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from photomodel.camera import PinholeCamera, StereoRig
from photomodel.geometry import invert_transform, make_transform
from photomodel.model import PhotoModel

__all__ = ["ModelFeatures", "PeerResult", "model_features", "sift_locate"]


@dataclass(frozen=True)
class ModelFeatures:
    """SIFT features of a photo-model.

    Parameters
    ----------
    name : str
        The model's name.
    points_mm : ndarray (N, 3)
        Keypoints on the garment plane, model frame, mm (z = 0).
    descriptors : ndarray (N, 128) float32
        Their SIFT descriptors.
    seconds : float
        Time taken to compute them.
    """

    name: str
    points_mm: NDArray[np.float64]
    descriptors: NDArray[np.float32]
    seconds: float

    @property
    def n(self) -> int:
        """Number of model keypoints."""
        return int(self.points_mm.shape[0])


@dataclass(frozen=True)
class PeerResult:
    """Outcome of :func:`sift_locate`.

    Parameters
    ----------
    T_cam1_model : ndarray (4, 4) or None
        Pose of the model in camera 1 (mm); None when ``ok`` is False.
    ok : bool
        A pose was found.
    seconds : float
        Wall-clock time from the two images to the pose (model features excluded).
    inliers : int
        Matches of both cameras within ``inlier_px`` of the final pose (0 on failure before
        the refinement; RANSAC's inlier count when it failed there).
    reason : str
        Why it failed, or ``"ok"``.
    matches : tuple of int
        Matches after the ratio test in camera 1 and camera 2.
    """

    T_cam1_model: NDArray[np.float64] | None
    ok: bool
    seconds: float
    inliers: int
    reason: str
    matches: tuple[int, int] = (0, 0)


def _sift(n_features: int = 0) -> cv2.SIFT:
    return cv2.SIFT_create(nfeatures=n_features)


def _grey(image_bgr: NDArray[np.uint8]) -> NDArray[np.uint8]:
    return image_bgr if image_bgr.ndim == 2 else cv2.cvtColor(image_bgr, cv2.COLOR_BGR2GRAY)


def model_features(model: PhotoModel) -> ModelFeatures:
    """SIFT keypoints of the model photo inside its mask, on the model plane (model frame, mm).

    The pixel -> plane mapping replicates the model build's ``to_model`` exactly.
    """
    t0 = time.perf_counter()
    keypoints, descriptors = _sift().detectAndCompute(
        _grey(model.photo_bgr), (np.asarray(model.mask) > 0).astype(np.uint8))
    if descriptors is None or not keypoints:
        return ModelFeatures(model.name, np.zeros((0, 3)), np.zeros((0, 128), np.float32),
                             time.perf_counter() - t0)
    uv_crop = np.array([kp.pt for kp in keypoints], dtype=np.float64)
    uv = uv_crop + np.asarray(model.crop_origin_px, dtype=np.float64)
    meta = model.meta
    camera = PinholeCamera(np.asarray(meta["camera_K"], float), np.asarray(meta["camera_dist"]))
    centroid = np.asarray(meta["centroid_in_camera_mm"], dtype=np.float64)[:2]
    xy = camera.undistort_pixels(uv) * float(meta["distance_mm"]) - centroid
    points = np.column_stack([xy, np.zeros(len(xy))])
    return ModelFeatures(model.name, points, descriptors.astype(np.float32),
                         time.perf_counter() - t0)


def _match(features: ModelFeatures, descriptors: NDArray[np.float32] | None, ratio: float,
           matcher: cv2.DescriptorMatcher) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """(model index, scene index) pairs passing the ratio test, one per model point."""
    empty = np.zeros(0, np.intp)
    if descriptors is None or len(descriptors) < 2 or features.n < 2:
        return empty, empty
    knn = matcher.knnMatch(descriptors, features.descriptors, k=2)
    pairs = [(m[0].trainIdx, m[0].queryIdx, m[0].distance) for m in knn
             if len(m) == 2 and m[0].distance < ratio * m[1].distance]
    if not pairs:
        return empty, empty
    arr = np.array(pairs)
    order = np.lexsort((arr[:, 2], arr[:, 0]))  # by model index, then distance
    arr = arr[order]
    first = np.ones(len(arr), bool)
    first[1:] = arr[1:, 0] != arr[:-1, 0]
    arr = arr[first]
    return arr[:, 0].astype(np.intp), arr[:, 1].astype(np.intp)


def _pnp(points: NDArray[np.float64], uv: NDArray[np.float64], camera: PinholeCamera,
         ransac_px: float, iterations: int) -> tuple[NDArray[np.float64] | None, int]:
    """RANSAC PnP: (T_cam_model (4, 4) or None, inlier count)."""
    if len(points) < 6:
        return None, 0
    ok, rvec, tvec, inliers = cv2.solvePnPRansac(
        points.astype(np.float64), uv.astype(np.float64), camera.K, camera.dist,
        iterationsCount=iterations, reprojectionError=ransac_px, confidence=0.999,
        flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok or inliers is None:
        return None, 0
    return make_transform(cv2.Rodrigues(rvec)[0], tvec.ravel()), len(inliers)


def _residuals(pose: NDArray[np.float64], rig: StereoRig, p1: NDArray[np.float64],
               uv1: NDArray[np.float64], p2: NDArray[np.float64],
               uv2: NDArray[np.float64]) -> NDArray[np.float64]:
    """Reprojection residuals (px) of both cameras' matches for pose (rvec, t) of T_cam1_model."""
    rvec, tvec = pose[:3].reshape(3, 1), pose[3:].reshape(3, 1)
    r2vec, t2vec = cv2.composeRT(rvec, tvec, cv2.Rodrigues(rig.R)[0], rig.T.reshape(3, 1))[:2]
    out = []
    for pts, uv, cam, r, t in ((p1, uv1, rig.cam1, rvec, tvec), (p2, uv2, rig.cam2, r2vec, t2vec)):
        if len(pts):
            proj = cv2.projectPoints(pts, r, t, cam.K, cam.dist)[0].reshape(-1, 2)
            out.append((proj - uv).ravel())
    return np.concatenate(out)


def _reprojection_px(T_cam1_model: NDArray[np.float64], rig: StereoRig,
                     points: NDArray[np.float64], uv: NDArray[np.float64],
                     camera: int) -> NDArray[np.float64]:
    x1 = points @ T_cam1_model[:3, :3].T + T_cam1_model[:3, 3]
    if camera == 1:
        pred = rig.cam1.project(x1)
    else:
        pred = rig.cam2.project(x1 @ rig.R.T + rig.T)
    err = np.linalg.norm(pred - uv, axis=1)
    return np.where(np.isfinite(err), err, np.inf)


def sift_locate(
    model: PhotoModel,
    rig: StereoRig,
    right_bgr: NDArray[np.uint8],
    left_bgr: NDArray[np.uint8],
    *,
    ratio: float = 0.75,
    features: ModelFeatures | None = None,
    ransac_px: float = 4.0,
    ransac_iterations: int = 2000,
    min_matches: int = 10,
    min_inliers: int = 10,
    gate_px: float = 8.0,
    inlier_px: float = 3.0,
    loss: str = "soft_l1",
    f_scale_px: float = 1.5,
) -> PeerResult:
    """Pose ``T_cam1_model`` of ``model`` in a stereo pair by SIFT matching, PnP and refinement.

    Parameters
    ----------
    model : PhotoModel
    rig : StereoRig
        Camera 1 is the reference (right) camera; ``X2 = R X1 + T``.
    right_bgr, left_bgr : ndarray (H, W, 3) uint8
        Images of camera 1 and camera 2.
    ratio : float
        Lowe's ratio-test threshold.
    features : ModelFeatures, optional
        The model's features from :func:`model_features` (computed, untimed, when omitted).
    ransac_px, ransac_iterations : float, int
        ``cv2.solvePnPRansac`` reprojection threshold (px) and iteration count.
    min_matches, min_inliers : int
        Fewest ratio-test matches in the camera used for RANSAC, and fewest RANSAC inliers.
    gate_px, inlier_px : float
        Reprojection error (px) under which a match joins the refinement at first, and after it.
    loss, f_scale_px : str, float
        Robust loss of ``least_squares`` and its scale (px).

    Returns
    -------
    PeerResult
    """
    if not 0.0 < ratio <= 1.0:
        raise ValueError(f"ratio: expected a value in (0, 1], got {ratio}")
    rig.cam1.check_image(right_bgr, "right image")
    rig.cam2.check_image(left_bgr, "left image")
    feats = features if features is not None else model_features(model)
    t0 = time.perf_counter()

    def fail(reason: str, inliers: int = 0, matches: tuple[int, int] = (0, 0)) -> PeerResult:
        return PeerResult(None, False, time.perf_counter() - t0, inliers, reason, matches)

    sift = _sift()
    matcher = cv2.BFMatcher(cv2.NORM_L2)
    pts, uvs = [], []
    for image in (right_bgr, left_bgr):
        # Detection runs even when the model is featureless, so the time stays a stereo pair's.
        keypoints, descriptors = sift.detectAndCompute(_grey(image), None)
        if feats.n < min_matches:
            continue
        i_model, i_scene = _match(feats, descriptors, ratio, matcher)
        uv = np.array([keypoints[i].pt for i in i_scene], dtype=np.float64).reshape(-1, 2)
        pts.append(feats.points_mm[i_model])
        uvs.append(uv)
    if feats.n < min_matches:
        return fail(f"model has only {feats.n} SIFT keypoints (< {min_matches})")
    matches = (len(pts[0]), len(pts[1]))

    # Initial pose: RANSAC PnP in camera 1, else in camera 2 moved into camera 1.
    T, n_inl, why = None, 0, ""
    for cam in (1, 2):
        n = matches[cam - 1]
        if n < min_matches:
            why += f"camera {cam}: {n} matches (< {min_matches}); "
            continue
        T_cam, n_inl = _pnp(pts[cam - 1], uvs[cam - 1], rig.cameras[cam - 1], ransac_px,
                            ransac_iterations)
        if T_cam is None or n_inl < min_inliers:
            why += f"camera {cam}: {n_inl} RANSAC inliers (< {min_inliers}); "
            continue
        T = T_cam if cam == 1 else invert_transform(rig.T_cam2_cam1) @ T_cam
        break
    if T is None:
        return fail(why.rstrip("; "), n_inl, matches)

    # Joint robust refinement over both cameras, gated, then re-gated once.
    pose = np.concatenate([cv2.Rodrigues(T[:3, :3])[0].ravel(), T[:3, 3]])
    for gate in (gate_px, inlier_px):
        keep1 = _reprojection_px(T, rig, pts[0], uvs[0], 1) < gate
        keep2 = _reprojection_px(T, rig, pts[1], uvs[1], 2) < gate
        if keep1.sum() + keep2.sum() < min_inliers:
            return fail(f"{int(keep1.sum() + keep2.sum())} matches within {gate:g} px of the "
                        f"pose (< {min_inliers})", int(keep1.sum() + keep2.sum()), matches)
        sol = least_squares(_residuals, pose, loss=loss, f_scale=f_scale_px, x_scale="jac",
                            args=(rig, pts[0][keep1], uvs[0][keep1], pts[1][keep2],
                                  uvs[1][keep2]))
        pose = sol.x
        T = make_transform(cv2.Rodrigues(pose[:3])[0], pose[3:])
    inliers = int((_reprojection_px(T, rig, pts[0], uvs[0], 1) < inlier_px).sum()
                  + (_reprojection_px(T, rig, pts[1], uvs[1], 2) < inlier_px).sum())
    if T[2, 3] <= 0 or T[2, 2] <= 0:
        return fail("implausible pose (model behind camera 1 or seen from behind)", inliers,
                    matches)
    if inliers < min_inliers:
        return fail(f"{inliers} inliers after refinement (< {min_inliers})", inliers, matches)
    return PeerResult(T, True, time.perf_counter() - t0, inliers, "ok", matches)
