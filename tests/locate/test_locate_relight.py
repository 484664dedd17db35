"""A dim scene: the coarse scan relit with the light offsets the scene's colours suggest."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from photomodel.experiments._trials import ExperimentConfig, Trial, trial_inputs
from photomodel.fitness import StereoFeatures, scan_flat_poses
from photomodel.locate import COARSE_SCAN, LocateSettings, _locate, locate_in_features
from photomodel.search import SearchSpace


def test_a_dim_scene_is_found_from_the_relit_coarse_scan(monkeypatch: pytest.MonkeyPatch
                                                          ) -> None:
    """Under a dim lamp the coarse scan (the model station's light) is not trusted; relit it
    is, and the search from its peaks is the result: level 3's scans never run (they did,
    three of them, before the coarse scan was relit)."""
    config = ExperimentConfig(garments=("No.8",), conditions=("dim",), trials=2, seed=0)
    model, rig, right, left, T_true, _ = trial_inputs(config, Trial("dim_No.8_0001", "No.8",
                                                                    "dim", 1))
    features = StereoFeatures(rig, right, left)
    space = SearchSpace.from_ranges(R_cam1_plane=rig.R_cam1_facing)
    assert not scan_flat_poses(model, features, space.lower, space.upper, COARSE_SCAN).trusted
    levels: list[int] = []
    scan = _locate.scan_flat_poses

    def counted(*args, **kwargs):  # type: ignore[no-untyped-def]
        levels.append(args[4].level if len(args) > 4 and args[4] is not None else 3)
        return scan(*args, **kwargs)

    monkeypatch.setattr(_locate, "scan_flat_poses", counted)
    result = locate_in_features(model, features, rng=0)
    assert result.found and levels == [4]
    assert np.linalg.norm(result.T_cam1_model[:3, 3] - T_true[:3, 3]) < 3.0
    levels.clear()
    unlit = locate_in_features(model, features, rng=0, settings=LocateSettings(
        coarse_scan=replace(COARSE_SCAN, relight=0)))
    assert unlit.found and levels == [4, 3]
