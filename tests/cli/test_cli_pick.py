"""``photomodel pick``, ``handeye`` and ``cell`` on real files: the plan, and clean errors.

Errors follow docs/contracts.md ("Command line"): one line on stderr naming the file or option
and the problem, exit code 2, no traceback, nothing half-written.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from photomodel.camera import save_stereo
from photomodel.cell import CellConfig, make_cell
from photomodel.cli import main
from photomodel.geometry import invert_transform, make_transform
from photomodel.model import build_photo_model, save_model
from photomodel.robot import forward_kinematics, inverse_kinematics, load_hand_eye, save_hand_eye
from photomodel.sim import (
    MODEL_DISTANCE_MM,
    make_garment,
    model_station_camera,
    random_stereo_scene,
    render_model_photos,
)


@dataclass(frozen=True)
class PickData:
    root: Path
    stereo: Path
    right: Path
    left: Path
    model: Path
    hand_eye: Path
    joints_deg: list[float]
    T_base_model: np.ndarray
    T_base_hand: np.ndarray


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> PickData:
    root = tmp_path_factory.mktemp("pick_data")
    setup = make_cell(CellConfig(hand_eye="true"))
    garment = make_garment("tshirt", "plain", (150, 120), rng=1)
    camera = model_station_camera()
    photo, background = render_model_photos(garment, camera, rng=2)
    scene = random_stereo_scene(garment, setup.rig, rng=3)
    save_stereo(root / "stereo.yaml", setup.rig)
    save_hand_eye(root / "hand_eye.yaml", setup.T_hand_cam1_true)
    for name, image in (("right.png", scene.right_bgr), ("left.png", scene.left_bgr)):
        assert cv2.imwrite(str(root / name), image)
    built = build_photo_model(photo, background, camera, MODEL_DISTANCE_MM, name="garment")
    save_model(built.model, root / "garment.npz")
    T_base_hand = forward_kinematics(setup.arm, setup.q_photo)
    return PickData(root, root / "stereo.yaml", root / "right.png", root / "left.png",
                    root / "garment.npz", root / "hand_eye.yaml",
                    np.degrees(setup.q_photo).tolist(),
                    T_base_hand @ setup.T_hand_cam1_true @ scene.T_cam1_model, T_base_hand)


def _run(capsys: pytest.CaptureFixture[str], argv: list[object]) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _assert_clean_error(code: int, out: str, err: str, needle: str, out_dir: Path) -> str:
    assert code == 2, err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("photomodel: error: "), lines[0]
    assert needle in lines[0], lines[0]
    assert out == ""
    written = sorted(p.name for p in out_dir.rglob("*")) if out_dir.exists() else []
    assert written == [], f"half-written output: {written}"
    return lines[0]


def _pick_argv(data: PickData, out_dir: Path, *extra: object,
               joints: list[float] | None = None) -> list[object]:
    joints = data.joints_deg if joints is None else joints
    return ["pick", "--model", data.model, "--stereo", data.stereo, "--right", data.right,
            "--left", data.left, "--hand-eye", data.hand_eye, "--joints-deg", *joints,
            "--out", out_dir / "plan.json", *extra]


def test_pick_plans_and_animates(capsys, data: PickData, tmp_path: Path) -> None:
    out_dir = tmp_path / "out"
    code, out, err = _run(capsys, _pick_argv(data, out_dir, "--animate", out_dir / "pick.gif"))
    assert code == 0, err
    plan = json.loads(out)
    assert plan == json.loads((out_dir / "plan.json").read_text())
    assert plan["locate"]["found"] and plan["reachable"] and plan["within_limits"]
    assert [w["name"] for w in plan["waypoints"]] == ["start", "pre_grasp", "grasp", "lift",
                                                      "pre_place", "place", "retreat"]
    error = np.linalg.norm(np.array(plan["grasp_point_mm"]) - data.T_base_model[:3, 3])
    assert error < 5.0, error
    np.testing.assert_allclose(plan["waypoints"][0]["joints_deg"], data.joints_deg)
    gif = out_dir / "pick.gif"
    assert gif.read_bytes()[:6] in (b"GIF89a", b"GIF87a")
    assert gif.stat().st_size < 2_000_000
    assert sorted(p.name for p in out_dir.iterdir()) == ["pick.gif", "plan.json"]


def test_pick_from_a_hand_pose(capsys, data: PickData, tmp_path: Path) -> None:
    T = data.T_base_hand
    rpy = Rotation.from_matrix(T[:3, :3]).as_euler("xyz", degrees=True)
    argv = ["pick", "--model", data.model, "--stereo", data.stereo, "--right", data.right,
            "--left", data.left, "--hand-eye", data.hand_eye,
            "--hand-pose-mm", *T[:3, 3], "--hand-rpy-deg", *(f"{a:.6f}" for a in rpy)]
    code, out, err = _run(capsys, argv)
    assert code == 0, err
    plan = json.loads(out)
    np.testing.assert_allclose(plan["T_base_hand"], T, atol=1e-2)
    assert np.linalg.norm(np.array(plan["grasp_point_mm"]) - data.T_base_model[:3, 3]) < 5.0


def test_pick_missing_hand_eye(capsys, data: PickData, tmp_path: Path) -> None:
    missing = tmp_path / "no_hand_eye.yaml"
    argv = _pick_argv(data, tmp_path / "out")
    argv[argv.index(data.hand_eye)] = missing
    line = _assert_clean_error(*_run(capsys, argv), missing.name, tmp_path / "out")
    assert "not found" in line


def test_pick_missing_model(capsys, data: PickData, tmp_path: Path) -> None:
    missing = tmp_path / "no_model.npz"
    argv = _pick_argv(data, tmp_path / "out")
    argv[argv.index(data.model)] = missing
    _assert_clean_error(*_run(capsys, argv), missing.name, tmp_path / "out")


def test_pick_bad_joint_count(capsys, data: PickData, tmp_path: Path) -> None:
    argv = _pick_argv(data, tmp_path / "out", joints=data.joints_deg[:6])
    line = _assert_clean_error(*_run(capsys, argv), "--joints-deg", tmp_path / "out")
    assert "expected 7 joint angles" in line


def test_pick_joints_outside_limits(capsys, data: PickData, tmp_path: Path) -> None:
    joints = list(data.joints_deg)
    joints[3] = 150.0
    line = _assert_clean_error(*_run(capsys, _pick_argv(data, tmp_path / "out", joints=joints)),
                               "--joints-deg", tmp_path / "out")
    assert "E1" in line and "outside its limits" in line


@pytest.mark.slow
def test_pick_box_out_of_reach(capsys, data: PickData, tmp_path: Path) -> None:
    out_dir = tmp_path / "out"
    argv = _pick_argv(data, out_dir, "--box-mm", 0, -1500, 0, "--animate", out_dir / "a.gif")
    line = _assert_clean_error(*_run(capsys, argv), "out of reach", out_dir)
    assert "pre_place" in line


def test_pick_hand_pose_out_of_reach(capsys, data: PickData, tmp_path: Path) -> None:
    argv = ["pick", "--model", data.model, "--stereo", data.stereo, "--right", data.right,
            "--left", data.left, "--hand-eye", data.hand_eye, "--hand-pose-mm", 2000, 0, 500]
    _assert_clean_error(*_run(capsys, argv), "--hand-pose-mm", tmp_path / "out")


def test_pick_unknown_animation_type(capsys, data: PickData, tmp_path: Path) -> None:
    out_dir = tmp_path / "out"
    argv = _pick_argv(data, out_dir, "--animate", out_dir / "motion.avi")
    _assert_clean_error(*_run(capsys, argv), "motion.avi", out_dir)


@pytest.mark.skipif(shutil.which("ffmpeg") is not None, reason="ffmpeg is installed")
def test_pick_mp4_without_ffmpeg(capsys, data: PickData, tmp_path: Path) -> None:
    out_dir = tmp_path / "out"
    argv = _pick_argv(data, out_dir, "--animate", out_dir / "motion.mp4")
    line = _assert_clean_error(*_run(capsys, argv), "motion.mp4", out_dir)
    assert "ffmpeg" in line


# --- handeye -------------------------------------------------------------------------------


def _pairs_file(path: Path, n: int, X: np.ndarray, q_centre: np.ndarray) -> None:
    from photomodel.robot import load_arm

    arm = load_arm()
    rng = np.random.default_rng(0)
    T_photo = forward_kinematics(arm, q_centre)
    T_base_target = T_photo @ X @ make_transform(np.eye(3), [0.0, 0.0, 650.0])
    pairs = []
    while len(pairs) < n:
        dR = Rotation.from_rotvec(rng.normal(size=3) * np.radians(12.0)).as_matrix()
        res = inverse_kinematics(arm, T_photo @ make_transform(dR, rng.uniform(-50, 50, 3)),
                                 q_centre, rng=rng)
        if res.success:
            T_obs = invert_transform(forward_kinematics(arm, res.q) @ X) @ T_base_target
            pairs.append({"joints_deg": np.degrees(res.q).tolist(),
                          "T_cam1_target": T_obs.tolist()})
    path.write_text(json.dumps({"pairs": pairs}))


def test_handeye_calibrates(capsys, data: PickData, tmp_path: Path) -> None:
    X = load_hand_eye(data.hand_eye)
    pairs = tmp_path / "pairs.json"
    _pairs_file(pairs, 8, X, np.radians(data.joints_deg))
    out = tmp_path / "out" / "hand_eye.yaml"
    code, stdout, err = _run(capsys, ["handeye", "--pairs", pairs, "--out", out, "--json"])
    assert code == 0, err
    result = json.loads(stdout)
    np.testing.assert_allclose(load_hand_eye(out), X, atol=1e-3)
    assert result["n_pairs"] == 8 and result["residual_mm"] < 1e-3


def test_handeye_missing_pairs(capsys, tmp_path: Path) -> None:
    missing = tmp_path / "no_pairs.json"
    out_dir = tmp_path / "out"
    line = _assert_clean_error(*_run(capsys, ["handeye", "--pairs", missing, "--out",
                                              out_dir / "he.yaml"]), missing.name, out_dir)
    assert "not found" in line


def test_handeye_too_few_pairs(capsys, tmp_path: Path) -> None:
    pairs = tmp_path / "pairs.json"
    pairs.write_text(json.dumps({"pairs": [{"joints_deg": [0] * 7,
                                            "T_cam1_target": np.eye(4).tolist()}] * 2}))
    out_dir = tmp_path / "out"
    _assert_clean_error(*_run(capsys, ["handeye", "--pairs", pairs, "--out",
                                       out_dir / "he.yaml"]), "at least 3 pairs", out_dir)


def test_handeye_corrupt_pairs(capsys, tmp_path: Path) -> None:
    pairs = tmp_path / "pairs.json"
    pairs.write_bytes(b"\x00\xff not json")
    out_dir = tmp_path / "out"
    _assert_clean_error(*_run(capsys, ["handeye", "--pairs", pairs, "--out",
                                       out_dir / "he.yaml"]), pairs.name, out_dir)


# --- cell ----------------------------------------------------------------------------------


@pytest.mark.parametrize(("args", "needle"), [
    (["--garments", "No.99"], "--garments"),
    (["--condition", "sunny"], "--condition"),
    (["--orders", "0"], "orders"),
    (["--animate", "cell.avi"], "cell.avi"),
    (["--tables", "0"], "--tables"),
    (["--tables", "2", "--garments", "No.3"], "--garments"),
    (["--tables", "2", "--garments", "7"], "--garments"),
])
def test_cell_bad_options(capsys, tmp_path: Path, args: list[str], needle: str) -> None:
    out_dir = tmp_path / "out"
    argv = ["cell", "--out", out_dir / "cell.json", *args]
    _assert_clean_error(*_run(capsys, argv), needle, out_dir)
