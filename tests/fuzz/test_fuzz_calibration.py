"""Fuzzing the calibration loaders: mutated OpenCV YAML, XML and JSON files (the project's
own, and plain ones), ROS camera_info files and CameraInfo messages are read as a plausible
camera or rig or refused with InputError, within a bounded address space."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fuzz_helpers import Tally, bounded_call, fuzz_settings, mutated_calibration
from fuzz_stderr import stderr_of_run
from hypothesis import given
from hypothesis import strategies as st

from photomodel._limits import FOCAL_PX_RANGE
from photomodel.camera import PinholeCamera, load_camera, load_distance_mm, load_stereo


def _plausible(camera: PinholeCamera) -> None:
    assert np.isfinite(camera.K).all() and np.isfinite(camera.dist).all()
    assert FOCAL_PX_RANGE[0] <= camera.K[0, 0] <= FOCAL_PX_RANGE[1]
    assert camera.width_px >= 0 and camera.height_px >= 0


@pytest.mark.parametrize("profile", ["short", pytest.param("long", marks=pytest.mark.slow)])
def test_fuzzed_calibrations_load_or_raise_input_error(profile: str, tallies,
                                                       calibration_seeds,
                                                       tmp_path: Path) -> None:
    tally = tallies[profile].setdefault("calibration", Tally())
    names = sorted(calibration_seeds)

    @fuzz_settings("calibration", long=profile == "long")
    @given(data=st.data())
    def run(data: st.DataObject) -> None:
        name = data.draw(st.sampled_from(names), label="seed")
        blob = data.draw(mutated_calibration(calibration_seeds[name]), label="text")
        path = tmp_path / f"fuzzed{Path(name).suffix}"
        path.write_bytes(blob)
        loader = data.draw(st.sampled_from((load_stereo, load_camera, load_distance_mm)),
                           label="loader")
        result = bounded_call(tally, loader, path)
        if loader is load_stereo and result is not None:
            _plausible(result.cam1)
            _plausible(result.cam2)
            assert np.isfinite(result.R).all() and np.isfinite(result.T).all()
        elif loader is load_camera and result is not None:
            _plausible(result)
        elif result is not None:
            assert 0 < result < float("inf")

    with stderr_of_run() as written:
        run()
    assert written == [""], written
    assert tally.other_exceptions == 0
    assert tally.accepted and tally.input_errors
