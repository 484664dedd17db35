"""identify: the right model and its pose, none on an empty table, the JSON contract."""

from __future__ import annotations

import numpy as np
import pytest
from identify_helpers import IdentifyData

from photomodel.fitness import StereoFeatures
from photomodel.identify import (
    DescriptorBank,
    IdentifyConfig,
    identify,
    identify_in_features,
    scene_regions,
)
from photomodel.locate import locate_in_features
from photomodel.model import describe_model

LOCATE_KEYS = {"model", "found", "T_cam1_model", "position_mm", "quat_wxyz", "theta_deg",
               "fitness", "score", "seconds"}


def test_screening_ranks_the_garment_on_the_table(identify_data: IdentifyData) -> None:
    d = identify_data
    names = [m.name for m in d.models]
    bank = DescriptorBank(names, [describe_model(m) for m in d.models])
    scene = scene_regions(StereoFeatures(d.rig, d.scene_right, d.scene_left))
    assert len(scene.regions) >= 1
    # the table's depth from stereo, along camera 1's axis, near the garment's
    assert abs(scene.table_depth_mm - d.T_cam1_model[2, 3]) < 0.05 * d.T_cam1_model[2, 3]
    ev = bank.evidence(scene)
    assert ev.shape == (3,) and np.all((ev >= 0) & (ev <= 1))
    assert names[int(np.argmax(ev))] == "No.5" and ev.max() > 0.7
    empty = scene_regions(StereoFeatures(d.rig, d.empty_right, d.empty_left))
    assert empty.regions == () and np.all(bank.evidence(empty) == 0)


def test_identify_names_the_garment_with_locates_pose(identify_data: IdentifyData) -> None:
    d = identify_data
    result = identify(d.models, d.rig, d.scene_right, d.scene_left,
                      config=IdentifyConfig(max_candidates=2), rng=3)
    assert result.found and result.model == "No.5"
    assert result.best is not None
    assert np.linalg.norm(result.best.position_mm - d.T_cam1_model[:3, 3]) < 10.0
    # The other candidate's colours agree nowhere (its scan is not trusted): once No.5,
    # whose scan is trusted, is found, it is not searched.
    assert result.runner_up is None
    assert [c.model for c in result.candidates if c.result is not None] == ["No.5"]
    doc = result.to_json_dict()
    assert LOCATE_KEYS <= set(doc) and doc["model"] == "No.5" and doc["found"] is True
    assert doc["runner_up"] == {"model": None, "score": None} and 0 <= doc["score"] <= 1
    every = identify(d.models, d.rig, d.scene_right, d.scene_left,
                     config=IdentifyConfig(max_candidates=2, trusted_first=False,
                                           candidate_margin=1.0, evidence_margin=1.0,
                                           min_evidence=0.0), rng=3)
    assert every.model == "No.5" and every.score == pytest.approx(result.score)
    assert every.runner_up is not None and every.runner_up.model != "No.5"
    assert every.runner_up.score is not None and every.runner_up.score < every.score
    searched = [c for c in every.candidates if c.result is not None]
    assert len(searched) == 2  # the third model was dropped by the screen (max_candidates)
    assert set(every.to_json_dict()["runner_up"]) == {"model", "score"}


def test_identify_says_none_on_an_empty_table(identify_data: IdentifyData) -> None:
    d = identify_data
    result = identify(d.models, d.rig, d.empty_right, d.empty_left,
                      config=IdentifyConfig(max_candidates=1, retries=0), rng=0)
    assert not result.found and result.model is None
    doc = result.to_json_dict()
    assert doc["model"] is None and doc["found"] is False and doc["T_cam1_model"] is None
    assert LOCATE_KEYS <= set(doc) and doc["runner_up"] == {"model": None, "score": None}
    assert doc["score"] < doc["min_score"]


def test_a_model_searched_alone_matches_locate_in_features(identify_data: IdentifyData
                                                           ) -> None:
    """With one candidate and no screen, identify's pose is the plain locate's (its coarse
    scan first, as ``locate`` runs it), with the candidate's own seed."""
    d = identify_data
    features = StereoFeatures(d.rig, d.scene_right, d.scene_left)
    model = d.models[1]
    res = identify_in_features([model], features,
                               config=IdentifyConfig(min_evidence=0.0, retries=0), rng=7)
    assert res.best is not None
    from photomodel.identify._identify import _model_rng

    base = int(np.random.default_rng(7).integers(0, 2**62))
    plain = locate_in_features(model, features, rng=_model_rng(base, model.name, 0))
    np.testing.assert_allclose(res.best.T_cam1_model, plain.T_cam1_model)
    assert res.score == pytest.approx(plain.score)


def test_config_validation() -> None:
    with pytest.raises(ValueError, match="max_candidates"):
        IdentifyConfig(max_candidates=0)
    with pytest.raises(ValueError, match="min_score"):
        IdentifyConfig(min_score=2.0)
    with pytest.raises(ValueError, match="retries"):
        IdentifyConfig(retries=-1)


def test_an_identifier_prepares_its_library_and_gives_identifys_answer(
        identify_data: IdentifyData, tmp_path) -> None:  # type: ignore[no-untyped-def]
    """``Identifier(ModelLibrary(dir), rig)`` answers as ``identify`` on the same models, and
    a library file that does not load is skipped with one warning."""
    import shutil
    import warnings

    from photomodel import Identifier, ModelLibrary

    d = identify_data
    library = tmp_path / "library"
    shutil.copytree(d.library, library)
    (library / "broken.npz").write_bytes(b"not a model")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        identifier = Identifier(ModelLibrary(library), d.rig,
                                config=IdentifyConfig(max_candidates=2))
    assert [str(w.message).split(":")[0] for w in caught] == [str(library / "broken.npz")]
    assert sorted(identifier.names) == sorted(m.name for m in d.models)
    assert identifier.stats().prepared == 0      # opened from the index: nothing prepared
    result = identifier(d.scene_right, d.scene_left, rng=3)
    assert result.found and result.model == "No.5"
    searched = {c.model for c in result.candidates if c.result is not None}
    assert identifier.stats().prepared == len(searched)   # only the verified ones
    again = identify(d.models, d.rig, d.scene_right, d.scene_left,
                     config=IdentifyConfig(max_candidates=2, min_score=identifier.min_score),
                     rng=3)
    np.testing.assert_array_equal(result.best.T_cam1_model, again.best.T_cam1_model)
