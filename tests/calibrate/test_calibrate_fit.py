"""The fits on exact corners (projected, plus noise): every distortion model, intrinsics fixed
or refined, without rendering."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from calib_helpers import BOARD, board_poses
from scipy.spatial.transform import Rotation

from photomodel.calibrate import Detection, ViewCorners, calibrate_camera, calibrate_stereo
from photomodel.camera import PinholeCamera
from photomodel.errors import InputError
from photomodel.sim import hand_stereo_rig


def _views(camera: PinholeCamera, poses: list[np.ndarray], rng: np.random.Generator,
           missing: tuple[int, ...] = ()) -> list[ViewCorners]:
    out = []
    for k, T in enumerate(poses):
        uv = camera.project(BOARD.object_points() @ T[:3, :3].T + T[:3, 3])
        detection = (Detection(None, "", "no 9x6 chessboard found") if k in missing else
                     Detection(uv + rng.normal(0.0, 0.03, uv.shape), "sb"))
        out.append(ViewCorners(f"{k:03d}", Path(f"{k:03d}.png"), camera.image_size, detection))
    return out


@pytest.mark.parametrize("distortion", [4, 5, 8])
@pytest.mark.parametrize("refine", [True, False])
def test_stereo_fit_on_exact_corners(distortion: int, refine: bool) -> None:
    rig = hand_stereo_rig()
    poses = board_poses([(rig.cam1, np.eye(4)), (rig.cam2, rig.T_cam2_cam1)], BOARD, 15, 3)
    gen = np.random.default_rng(1)
    right = _views(rig.cam1, poses, gen, missing=(4,))
    left = _views(rig.cam2, [rig.T_cam2_cam1 @ T for T in poses], gen, missing=(9,))
    result = calibrate_stereo(right, left, BOARD, distortion=distortion,
                              refine_intrinsics=refine)
    assert result.rms_px < 0.05
    assert result.rig.cam1.dist.size == max(distortion, 5)
    assert result.cam1.views == tuple(f"{k:03d}" for k in range(15) if k != 4)
    assert [s.name for s in result.skipped] == ["004", "009"]
    assert "found in right" in result.skipped[0].reason
    assert result.per_pair_rms_px.shape == (13, 2)
    rotation = np.degrees(Rotation.from_matrix(result.rig.R @ rig.R.T).magnitude())
    # fixed intrinsics carry each camera's own errors into R, T (why refining is the default)
    baseline_mm, rotation_deg = (0.2, 0.05) if refine else (0.5, 0.25)
    assert abs(result.baseline_mm - np.linalg.norm(rig.T)) < baseline_mm
    assert rotation < rotation_deg
    for est, true in ((result.rig.cam1, rig.cam1), (result.rig.cam2, rig.cam2)):
        np.testing.assert_allclose(np.diag(est.K)[:2], np.diag(true.K)[:2], rtol=0.002)
        np.testing.assert_allclose(est.K[:2, 2], true.K[:2, 2], atol=1.5)


def test_too_few_views_name_the_missing_ones() -> None:
    camera = hand_stereo_rig().cam1
    poses = board_poses([(camera, np.eye(4))], BOARD, 4, 2)
    views = _views(camera, poses, np.random.default_rng(0), missing=(1, 3))
    with pytest.raises(InputError, match="needs at least 3 views in which the 9x6 chessboard "
                                         "is found; found in 2 of 4: 001: no 9x6 chessboard "
                                         "found; 003: no 9x6 chessboard found"):
        calibrate_camera(views, BOARD, source="views")


def test_a_square_board_is_refused_for_a_stereo_rig() -> None:
    from photomodel.calibrate import Chessboard

    with pytest.raises(InputError, match="looks the same turned by 90 degrees"):
        calibrate_stereo([], [], Chessboard((6, 6), 25.0))
