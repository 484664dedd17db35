"""Shared fixtures for the simulator's tests."""

from __future__ import annotations

import pytest

from photomodel.camera import StereoRig
from photomodel.sim import hand_stereo_rig


@pytest.fixture(scope="session")
def rig() -> StereoRig:
    return hand_stereo_rig()


@pytest.fixture(scope="session")
def rig_undistorted() -> StereoRig:
    return hand_stereo_rig(distortion=False)
