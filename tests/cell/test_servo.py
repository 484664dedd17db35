"""The servoed pick: its prediction, its joint rates, the conveyor's frames, one order each way,
and ``photomodel cell --servo`` with its animation and its option errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from photomodel.cell import CellConfig, ServoSettings, make_cell, run_servo_order
from photomodel.cell._servo import _joint_rates, _LineFit, _tcp_jacobian
from photomodel.cli import main
from photomodel.geometry import invert_transform, make_transform
from photomodel.robot import Gripper, forward_kinematics
from photomodel.sim import ConveyorView, hand_table_pose


@pytest.fixture(scope="module")
def config() -> CellConfig:
    return CellConfig(orders=1, garments=("No.6",), seed=0)


@pytest.fixture(scope="module")
def setup(config: CellConfig):  # type: ignore[no-untyped-def]
    return make_cell(config)


def test_line_fit_recovers_a_constant_velocity_and_forgets_old_measurements() -> None:
    fit = _LineFit(window_s=0.2)
    v = np.array([0.0, -200.0, 3.0])
    for k in range(12):
        t = k / 30.0
        fit.add(t, make_transform(np.eye(3), [600.0, 0.0, 5.0] + v * t))
    np.testing.assert_allclose(fit.velocity(), v, atol=1e-9)
    np.testing.assert_allclose(fit.predict(0.5)[:3, 3], [600.0, -100.0, 6.5], atol=1e-9)
    assert len(fit) == 7            # 0.2 s at 30 fps, both ends kept
    known = _LineFit(0.4, velocity_mm_s=np.array([1.0, 2.0, 0.0]))
    known.add(0.0, np.eye(4))
    np.testing.assert_allclose(known.predict(2.0)[:3, 3], [2.0, 4.0, 0.0])
    two = _LineFit(0.4, prior_mm_s=np.array([0.0, 7.0, 0.0]))
    two.add(0.0, np.eye(4))
    two.add(0.1, make_transform(np.eye(3), [5.0, 0.0, 0.0]))
    np.testing.assert_allclose(two.velocity(), [0.0, 7.0, 0.0])   # too few: the prior
    flat = _LineFit(1.0, normal=np.array([0.0, 0.0, -2.0]))
    for k in range(5):
        flat.add(k / 30.0, make_transform(np.eye(3), [0.0, 10.0 * k, 3.0 * k]))
    np.testing.assert_allclose(flat.velocity(), [0.0, 300.0, 0.0], atol=1e-9)  # in the plane


def test_tcp_jacobian_and_joint_rates_move_the_tcp_as_asked(setup) -> None:  # type: ignore[no-untyped-def]
    arm, q = setup.arm, setup.q_photo
    tcp_mm = Gripper().tcp_mm
    T_hand_tcp = Gripper().T_hand_tcp
    J = _tcp_jacobian(arm, q, tcp_mm)
    h = 1e-6
    for j in range(arm.n_joints):
        dq = np.zeros(arm.n_joints)
        dq[j] = h
        T0 = forward_kinematics(arm, q) @ T_hand_tcp
        T1 = forward_kinematics(arm, q + dq) @ T_hand_tcp
        np.testing.assert_allclose((T1[:3, 3] - T0[:3, 3]) / h, J[:3, j], atol=1e-3)
    twist = np.array([120.0, -200.0, -250.0, 0.1, -0.05, 0.3])
    qdot = _joint_rates(arm, q, tcp_mm, twist)
    np.testing.assert_allclose(J @ qdot, twist, rtol=1e-3, atol=1e-3)


def test_conveyor_view_carries_the_garment_and_tells_the_truth(setup) -> None:  # type: ignore[no-untyped-def]
    view = ConveyorView("No.6", speed_mm_s=200.0, seed=3, key=(1,), rig=setup.rig)
    T_table_cam1 = invert_transform(hand_table_pose(setup.rig))
    a = view.frame(0, 0.0, lambda t: T_table_cam1)
    b = view.frame(3, 0.1, lambda t: T_table_cam1)
    assert a.visible > 0.99 and a.right_bgr.shape == (480, 640, 3)
    moved = view.T_table_model(0.1)[:3, 3] - view.T_table_model(0.0)[:3, 3]
    np.testing.assert_allclose(moved, [0.0, 20.0, 0.0], atol=1e-9)
    assert b.T_cam1_model is not None
    np.testing.assert_allclose(b.T_cam1_model, hand_table_pose(setup.rig)
                               @ view.T_table_model(0.1), atol=1e-9)
    again = ConveyorView("No.6", speed_mm_s=200.0, seed=3, key=(1,), rig=setup.rig)
    assert np.array_equal(again.frame(0, 0.0, lambda t: T_table_cam1).right_bgr, a.right_bgr)
    with pytest.raises(ValueError, match="speed_mm_s"):
        ConveyorView("No.6", speed_mm_s=-1.0, seed=0)


def test_servo_settings_refuse_what_cannot_run() -> None:
    with pytest.raises(ValueError, match="fps"):
        ServoSettings(fps=0.0)
    with pytest.raises(ValueError, match="conveyor_mm_s"):
        ServoSettings(conveyor_mm_s=float("nan"))


def test_one_order_open_loop_misses_and_the_servo_hits(config, setup) -> None:  # type: ignore[no-untyped-def]
    servo = ServoSettings(fps=15.0)
    out = run_servo_order(config, setup, servo, 0, keep_ticks=True)
    r = out.record
    assert r["found"]
    travel = servo.conveyor_mm_s * r["open_loop"]["close_s"]
    assert r["open_loop"]["closed"] and r["open_loop"]["grasp_error_norm_mm"] > 0.8 * travel
    for mode in ("belt", "servo"):
        assert r[mode]["closed"], r[mode]
        assert r[mode]["grasp_error_norm_mm"] < 5.0, (mode, r[mode])
    s = r["servo"]
    assert s["frames"] >= 10 and s["used"] >= 10 and s["gated"] <= 2
    assert 0.0 < s["blind_s"] < 1.5
    assert out.ticks and out.ticks[0].image is not None and out.ticks[0].mode == "detect"
    assert any(t.mode == "track" for t in out.ticks)


def test_cli_cell_servo_writes_summary_json_and_animation(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    gif, out = tmp_path / "servo.gif", tmp_path / "servo.json"
    code = main(["cell", "--servo", "--orders", "1", "--garments", "No.6", "--fps", "10",
                 "--conveyor-mm-s", "150", "--animate", str(gif), "--out", str(out), "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    summary = json.loads(captured.out)
    assert set(summary["aims"]) == {"open_loop", "belt", "servo"}
    assert summary["servo"]["conveyor_mm_s"] == 150.0
    assert summary["aims"]["servo"]["within_tolerance"] == 1
    written = json.loads(out.read_text())
    assert written["cycles"][0]["servo"]["closed"] and "commit" in written
    assert gif.read_bytes()[:6] in (b"GIF89a", b"GIF87a")


@pytest.mark.parametrize("option, value, needle", [
    ("--conveyor-mm-s", "-5", "--conveyor-mm-s: expected a number from 0 to 500 mm/s"),
    ("--fps", "1000", "--fps: expected a number from 5 to 240 frames per second"),
    ("--fps", "nan", "--fps: expected a number"),
])
def test_cli_cell_servo_option_errors(option: str, value: str, needle: str,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["cell", "--servo", option, value])
    captured = capsys.readouterr()
    assert code == 2
    assert needle in captured.err and "Traceback" not in captured.err
    assert len(captured.err.strip().splitlines()) == 1
