"""identify: the right model and its pose, none on an empty table, the JSON contract."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from identify_helpers import IdentifyData

from photomodel.fitness import StereoFeatures, as_prepared, scene_regions
from photomodel.identify import (
    BankConfig,
    DescriptorBank,
    IdentifyConfig,
    identify,
    identify_in_features,
    identify_with_bank,
)
from photomodel.locate import locate_in_features
from photomodel.model import describe_model
from photomodel.model._descriptor import COLOUR_GRID_SHAPE, colour_grid_coords

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
    with pytest.raises(ValueError, match="min_visible_outline"):
        IdentifyConfig(min_visible_outline=1.5)
    with pytest.raises(ValueError, match="wide_candidates"):
        IdentifyConfig(wide_candidates=-1)


def _refine_reference(bank: DescriptorBank, scene, evidence: np.ndarray, refine: int
                      ) -> np.ndarray:
    """The pixel-by-pixel refinement written out in numpy (the module docstring)."""
    grid = np.asarray(COLOUR_GRID_SHAPE)
    steps = np.stack(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1], indexing="ij"),
                     -1).reshape(-1, 3)

    def cells(lab: np.ndarray) -> np.ndarray:
        c = np.round(colour_grid_coords(lab)).astype(np.int64)
        return np.ravel_multi_index(tuple(c.T), COLOUR_GRID_SHAPE)

    out = evidence.copy()
    for m in np.argsort(-evidence, kind="stable")[:refine]:
        near = (bank.bins[m][bank.weights[m] > 0.01][:, None, :] + steps[None]).reshape(-1, 3)
        near = near[np.all((near >= 0) & (near < grid), axis=1)]
        palette = np.zeros(int(np.prod(grid)), dtype=bool)
        palette[np.ravel_multi_index(tuple(near.T), COLOUR_GRID_SHAPE)] = True
        best = 0.0
        for region in scene.regions:
            shift = bank._light_shift(m, region.mean_lab, BankConfig())
            for explained in (palette[cells(region.lab)], palette[cells(region.lab - shift)]):
                n = int(np.count_nonzero(explained))
                if n < 3:
                    continue
                v = n * region.mm_per_px**2 / bank.area_mm2[m]
                xy = region.xy_mm[explained].astype(np.float64)
                moments = np.maximum(np.sort(np.linalg.eigvalsh(np.cov(xy.T)))[::-1], 1.0)
                shape = min(float(np.abs(np.log(moments / bank.moments_mm2[m])).sum()) / 0.5,
                            1.0)
                best = max(best, min(v, 1.0) - 0.5 * max(float(np.log(v)), 0.0)
                           - 0.3 * shape * min(v, 1.0))
        out[m] = 0.5 * evidence[m] + 0.5 * best
    return np.clip(out, 0.0, 1.0)


def test_the_compiled_refinement_matches_numpy(identify_data: IdentifyData) -> None:
    d = identify_data
    names = [m.name for m in d.models]
    bank = DescriptorBank(names, [describe_model(m) for m in d.models])
    scene = scene_regions(StereoFeatures(d.rig, d.scene_right, d.scene_left))
    first = bank.screen(scene)
    np.testing.assert_allclose(bank.refine(scene, first, BankConfig(refine=3)),
                               _refine_reference(bank, scene, first, 3), atol=1e-5)
    assert np.any(bank.refine(scene, first) != first)


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


class _FixedBank(DescriptorBank):
    """A bank whose screening evidence is given (the ranking under test)."""

    def __init__(self, names: list[str], descriptors: list, evidence: np.ndarray) -> None:
        super().__init__(names, descriptors)
        self.fixed = np.asarray(evidence, dtype=np.float64)

    def evidence(self, scene, config=None):  # type: ignore[no-untyped-def]
        return self.fixed.copy()


def test_a_garment_screened_low_is_verified_when_none_is_found(identify_data: IdentifyData
                                                               ) -> None:
    """A hidden garment screens lower than in full view: when the candidates within the
    margin are not found, the wider candidates whose scan is trusted are verified."""
    d = identify_data
    names = [m.name for m in d.models]
    prepared = [as_prepared(m) for m in d.models]
    truth = names.index("No.5")
    evidence = np.full(len(names), 0.9)
    evidence[truth] = 0.2
    bank = _FixedBank(names, [describe_model(m) for m in d.models], evidence)
    features = StereoFeatures(d.rig, d.scene_right, d.scene_left)
    narrow = IdentifyConfig(candidate_margin=0.3, wide_candidates=0, retries=0,
                            trusted_first=False)
    missed = identify_with_bank(bank, prepared.__getitem__, features, config=narrow, rng=1)
    assert missed.model is None
    assert [c.model for c in missed.candidates if c.result is not None] == [
        n for n in names if n != "No.5"]
    wide = identify_with_bank(bank, prepared.__getitem__, features,
                              config=replace(narrow, wide_candidates=len(names)), rng=1)
    assert wide.model == "No.5" and wide.found


def test_a_model_inside_a_region_of_its_colours_is_not_found(identify_data: IdentifyData
                                                             ) -> None:
    """Found needs the outline where the inside agrees: with an impossible visible-outline
    bar the same search finds nothing, and reports how close it came."""
    d = identify_data
    config = IdentifyConfig(max_candidates=1, retries=0)
    seen = identify(d.models, d.rig, d.scene_right, d.scene_left, config=config, rng=3)
    assert seen.found and seen.best is not None
    assert seen.best.visible_outline >= config.min_visible_outline
    strict = identify(d.models, d.rig, d.scene_right, d.scene_left,
                      config=replace(config, min_visible_outline=1.0), rng=3)
    assert not strict.found and strict.model is None
    assert strict.best is not None and strict.score == pytest.approx(seen.score)
