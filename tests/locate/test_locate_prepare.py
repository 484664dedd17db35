"""A model's preparation: its first stereo pair builds what later pairs would otherwise build."""

from __future__ import annotations

import numpy as np
import pytest

from photomodel.experiments._trials import ExperimentConfig, Trial, trial_inputs
from photomodel.fitness import ScanConfig, StereoFeatures, _samples, _scan, prepare_scan
from photomodel.locate import locate_in_features, prepare_model
from photomodel.search import PyramidConfig, SearchSpace


def _built(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The names of the model-side builders called from now on (samples' colours, scan
    kernels)."""
    calls: list[str] = []
    coloured, kernels = _samples._coloured, _scan._kernels

    def count_coloured(*args, **kwargs):  # type: ignore[no-untyped-def]
        calls.append("samples")
        return coloured(*args, **kwargs)

    def count_kernels(*args, **kwargs):  # type: ignore[no-untyped-def]
        calls.append("kernels")
        return kernels(*args, **kwargs)

    monkeypatch.setattr(_samples, "_coloured", count_coloured)
    monkeypatch.setattr(_scan, "_kernels", count_kernels)
    return calls


def test_after_the_first_pair_no_pair_builds_model_samples_or_scan_kernels(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The first pair prepares every level's samples with every blur the search may choose
    and both scans' kernels; a scene under a blurred lens (other blurs chosen) and a level-3
    scan then build nothing more, and the preparation is not repeated."""
    config = ExperimentConfig(garments=("No.3",), conditions=("paper", "blur"), trials=1,
                              seed=0)
    model, rig, right, left, _, _ = trial_inputs(config, Trial("paper_No.3_0000", "No.3",
                                                               "paper", 0))
    first = locate_in_features(model, StereoFeatures(rig, right, left), rng=0)
    assert first.found
    built = _built(monkeypatch)
    blurred, rig_b, right_b, left_b, T_true, _ = trial_inputs(
        config, Trial("blur_No.3_0000", "No.3", "blur", 0))
    assert blurred is model and rig_b is rig
    features = StereoFeatures(rig, right_b, left_b)
    result = locate_in_features(model, features, rng=0, coarse_scan=None)   # level 3's scan
    assert result.found and np.linalg.norm(result.T_cam1_model[:3, 3] - T_true[:3, 3]) < 3.0
    assert result.optics_blur_mm is not None and result.optics_blur_mm > 0.5
    assert built == []
    assert not prepare_model(model, features)


def test_a_preparation_for_other_settings_builds_their_samples(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Other blur candidates are another preparation: their samples are built, once."""
    config = ExperimentConfig(garments=("No.3",), conditions=("paper",), trials=1, seed=0)
    model, rig, right, left, _, _ = trial_inputs(config, Trial("paper_No.3_0000", "No.3",
                                                               "paper", 0))
    features = StereoFeatures(rig, right, left)
    prepare_model(model, features)
    built = _built(monkeypatch)
    other = PyramidConfig(optics_blur_candidates_mm=(0.5, 0.85, 1.7))
    assert prepare_model(model, features, pyramid=other)
    assert built == ["samples"] * 4        # 0.85 and 1.7 mm on levels 0 and 1
    assert not prepare_model(model, features, pyramid=other)


def test_prepare_scan_checks_the_level() -> None:
    config = ExperimentConfig(garments=("No.3",), conditions=("paper",), trials=1, seed=0)
    model, rig, right, left, _, _ = trial_inputs(config, Trial("paper_No.3_0000", "No.3",
                                                               "paper", 0))
    features = StereoFeatures(rig, right, left, levels=4)
    space = SearchSpace.from_ranges(R_cam1_plane=rig.R_cam1_facing)
    with pytest.raises(ValueError, match="level"):
        prepare_scan(model, features, space.lower, space.upper, ScanConfig(level=4))
