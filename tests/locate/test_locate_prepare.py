"""A Locator prepares its model once: no stereo pair builds model samples or scan kernels."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from photomodel.experiments._trials import ExperimentConfig, Trial, trial_inputs
from photomodel.fitness import (
    PreparedModel,
    ScanConfig,
    StereoFeatures,
    _samples,
    _scan,
    prepare_scan,
)
from photomodel.locate import COARSE_SCAN, LocateSettings, Locator, prepare_model
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


def _inputs(condition: str = "paper"):  # type: ignore[no-untyped-def]
    config = ExperimentConfig(garments=("No.3",), conditions=("paper", "blur"), trials=1,
                              seed=0)
    return trial_inputs(config, Trial(f"{condition}_No.3_0000", "No.3", condition, 0))


def test_a_locator_prepares_its_model_once_and_no_pair_builds_more(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Made, the locator holds every level's samples with every blur the search may choose
    and both scans' kernels; a scene under a blurred lens (other blurs chosen, level 3's scan)
    then builds nothing, in the locator's own state (no module cache)."""
    model, rig, right, left, T_true, _ = _inputs()
    counting = _built(monkeypatch)
    locate = Locator(model, rig)
    assert "samples" in counting and "kernels" in counting
    counting.clear()
    assert locate(right, left, rng=0).found
    blurred, rig_b, right_b, left_b, T_blur, _ = _inputs("blur")
    assert blurred is model and rig_b is rig
    result = locate.locate_features(StereoFeatures(rig, right_b, left_b), rng=0,
                                    settings=LocateSettings(coarse_scan=None))   # level 3's
    assert result.found and np.linalg.norm(result.T_cam1_model[:3, 3] - T_blur[:3, 3]) < 3.0
    assert result.optics_blur_mm is not None and result.optics_blur_mm > 0.5
    assert counting == []
    assert not locate.prepare(StereoFeatures(rig, right, left))
    other = Locator(model, rig)        # another locator prepares its own state
    assert counting and other.prepared is not locate.prepared


def test_a_locator_prepares_what_its_first_pair_would_to_the_bit() -> None:
    """The locator prepares on blank features (no images): the samples, their arrays and
    the scans' plans are those a preparation on a real pair of the rig builds."""
    model, rig, right, left, _, _ = _inputs()
    locator = Locator(model, rig)
    on_pair = PreparedModel(model)
    prepare_model(on_pair, StereoFeatures(rig, right, left), space=locator.space,
                  scans=(COARSE_SCAN, ScanConfig()))
    ours, theirs = locator.prepared.kept._values, on_pair.kept._values
    assert ours.keys() == theirs.keys()
    for key, value in ours.items():
        if isinstance(value, _samples.ModelSamples):
            for name in ("p_in", "f_in", "p_out", "f_out", "table_out"):
                np.testing.assert_array_equal(getattr(value, name),
                                              getattr(theirs[key], name))
    plans, other = ours["scan plans"], theirs["scan plans"]
    assert list(plans) == list(other)
    for key, groups in plans.items():
        for group, same in zip(groups, other[key], strict=True):
            for name in ("kernels", "depths", "sizes", "maps", "rays"):
                np.testing.assert_array_equal(getattr(group, name), getattr(same, name))


def test_calls_in_threads_give_the_same_poses_as_in_turn() -> None:
    model, rig, right, left, _, _ = _inputs()
    locate = Locator(model, rig)
    alone = [locate(right, left, rng=k).T_cam1_model for k in range(3)]
    together: dict[int, np.ndarray] = {}

    def run(k: int) -> None:
        together[k] = locate(right, left, rng=k).T_cam1_model

    threads = [threading.Thread(target=run, args=(k,)) for k in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for k in range(3):
        np.testing.assert_array_equal(together[k], alone[k])


def test_a_start_pose_searches_from_there_without_a_scan(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A tracker's call: from a pose near the answer, one search, no scan."""
    model, rig, right, left, T_true, _ = _inputs()
    locate = Locator(model, rig)
    scans: list[int] = []
    scan = _scan.scan_flat_poses

    def counted(*args, **kwargs):  # type: ignore[no-untyped-def]
        scans.append(1)
        return scan(*args, **kwargs)

    monkeypatch.setattr("photomodel.locate._locate.scan_flat_poses", counted)
    near = T_true.copy()
    near[:3, 3] += [4.0, -3.0, 6.0]
    result = locate(right, left, rng=0, start=near)
    assert scans == []
    assert result.found
    assert np.linalg.norm(result.T_cam1_model[:3, 3] - T_true[:3, 3]) < 2.0
    with pytest.raises(Exception, match="start"):
        locate(right, left, start=np.eye(3))


def test_a_preparation_for_other_settings_builds_their_samples(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Other blur candidates are another preparation: their samples are built, once."""
    model, rig, right, left, _, _ = _inputs()
    prepared = PreparedModel(model)
    features = StereoFeatures(rig, right, left)
    prepare_model(prepared, features)
    built = _built(monkeypatch)
    other = PyramidConfig(optics_blur_candidates_mm=(0.5, 0.85, 1.7))
    assert prepare_model(prepared, features, pyramid=other)
    assert built == ["samples"] * 4        # 0.85 and 1.7 mm on levels 0 and 1
    assert not prepare_model(prepared, features, pyramid=other)


def test_prepare_scan_checks_the_level() -> None:
    model, rig, right, left, _, _ = _inputs()
    features = StereoFeatures(rig, right, left, levels=4)
    space = SearchSpace.from_ranges(R_cam1_plane=rig.R_cam1_facing)
    with pytest.raises(ValueError, match="level"):
        prepare_scan(model, features, space.lower, space.upper, ScanConfig(level=4))


def test_the_locator_checks_its_arguments() -> None:
    model, rig, *_ = _inputs()
    with pytest.raises(TypeError, match="model"):
        Locator("shirt.npz", rig)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="method"):
        Locator(model, rig, method="fast")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="min_score"):
        Locator(model, rig, min_score=2.0)
    paper = Locator(model, rig, method="paper")
    assert paper.min_score == 0.5
