"""The simulated cell: the photographing pose sees the simulator's table; one order end to end."""

from __future__ import annotations

import numpy as np
import pytest

from photomodel.cell import CellConfig, make_cell, run_cycle
from photomodel.robot import forward_kinematics, hand_eye_error
from photomodel.sim import WORK_DISTANCE_MM, hand_table_pose, table_in_base


@pytest.fixture(scope="module")
def config() -> CellConfig:
    return CellConfig(orders=1, garments=("No.1",), condition="distractors", seed=0)


def test_photographing_pose_sees_the_table(config: CellConfig) -> None:
    setup = make_cell(config)
    T_base_cam1 = forward_kinematics(setup.arm, setup.q_photo) @ setup.T_hand_cam1_true
    T_base_table = T_base_cam1 @ hand_table_pose(setup.rig)
    np.testing.assert_allclose(T_base_table[:3, 3], config.layout.table_centre_mm, atol=1e-2)
    np.testing.assert_allclose(T_base_table[:3, 2], [0.0, 0.0, -1.0], atol=1e-6)
    np.testing.assert_allclose(T_base_table, table_in_base(config.layout), atol=1e-2)
    assert setup.arm.within_limits(setup.q_photo)
    # the rig's baseline middle hangs the working distance above the table
    rig_mid = T_base_cam1 @ np.append(-0.5 * setup.rig.R.T @ setup.rig.T, 1.0)
    assert abs(rig_mid[2] - WORK_DISTANCE_MM) < 1.0
    # the simulated calibration lands near the true mount
    err_mm, err_deg = hand_eye_error(setup.T_hand_cam1, setup.T_hand_cam1_true)
    assert err_mm < 3.0 and err_deg < 0.2
    assert setup.hand_eye_info["pairs"] == 12


def test_one_order_end_to_end(config: CellConfig) -> None:
    setup = make_cell(config)
    outcome = run_cycle(config, setup, 0)
    r = outcome.record
    assert r["found"] and r["planned"] and r["reachable"] and r["within_limits"]
    assert r["grasp_error_norm_mm"] < 6.0, r
    assert r["within_tolerance"]
    assert outcome.plan is not None
    np.testing.assert_allclose(outcome.plan.grasp_point_mm, r["est_grasp_mm"])
    np.testing.assert_allclose(outcome.T_base_model_true[:3, 3], r["true_grasp_mm"])
