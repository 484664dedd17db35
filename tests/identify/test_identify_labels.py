"""Labels: a QR code, DataMatrix or Code 128 rendered on a simulated garment is read in both
views with its corners where the truth puts them, a label too small to resolve gives no text,
and identify's answer carries the label beside the photo-model's answer: ``agrees`` true for
the right label map, false (the photo-model's answer unchanged) for a map naming another
model."""

from __future__ import annotations

import json
import sys

import cv2
import numpy as np
import pytest

pytest.importorskip("zxingcpp")

from identify_helpers import IdentifyData  # noqa: E402

from photomodel.errors import InputError  # noqa: E402
from photomodel.identify import (  # noqa: E402
    Identifier,
    IdentifyConfig,
    LabelRead,
    check_label,
    read_labels,
)
from photomodel.sim import (  # noqa: E402
    SimulatedScene,
    article_code,
    catalogue_garment,
    hand_stereo_rig,
    labelled_garment,
    parse_conditions,
    simulate_scene,
)
from photomodel.sim._labels import NOMINAL_PX_PER_MM, GarmentLabel  # noqa: E402


def _scene(name: str, fmt: str, module_px: float, seed: int, code: str | None = None
           ) -> tuple[SimulatedScene, GarmentLabel]:
    code = article_code(name, 0, fmt) if code is None else code
    garment = labelled_garment(catalogue_garment(name), code, fmt,
                               module_px / NOMINAL_PX_PER_MM, rng=seed)
    assert garment.label is not None
    return simulate_scene(garment, hand_stereo_rig(), parse_conditions("paper"),
                          rng=seed), garment.label


def _distance_to_outline(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    contour = polygon.astype(np.float32).reshape(-1, 1, 2)
    return np.array([abs(cv2.pointPolygonTest(contour, (float(u), float(v)), True))
                     for u, v in points])


@pytest.mark.parametrize("fmt, module_px, seed", [("QRCode", 3.0, 1), ("DataMatrix", 3.0, 2),
                                                  ("Code128", 2.3, 3)])
def test_a_rendered_label_is_read_in_both_views_where_the_truth_puts_it(
        fmt: str, module_px: float, seed: int) -> None:
    shot, label = _scene("No.8", fmt, module_px, seed)
    assert shot.T_cam1_model is not None
    truth = label.truth(hand_stereo_rig(), shot.T_cam1_model)
    assert min(truth["module_px"]) > 0.8 * module_px
    reads = read_labels(shot.right_bgr, shot.left_bgr)
    assert [(r.text, r.format) for r in reads] == [(label.text, fmt)]
    for key in ("corners_cam1", "corners_cam2"):
        found = getattr(reads[0], key)
        assert found is not None and found.shape == (4, 2), key
        true = np.asarray(truth[key])
        assert _distance_to_outline(found, true).max() < 2.0, (key, found, true)
        if fmt != "Code128":   # a linear code's corners end the lines that read it
            assert np.linalg.norm(found - true, axis=1).max() < 2.0, (key, found, true)


def test_a_label_too_small_to_resolve_gives_no_text() -> None:
    shot, _ = _scene("No.8", "QRCode", 0.8, 4)
    assert read_labels(shot.right_bgr, shot.left_bgr) == ()


def test_a_scene_without_labels_gives_none() -> None:
    shot = simulate_scene(catalogue_garment("No.1"), hand_stereo_rig(),
                          parse_conditions("distractors"), rng=5)
    assert read_labels(shot.right_bgr, shot.left_bgr, upscale=1) == ()


def test_read_labels_refuses_bad_settings_and_a_missing_zxing(monkeypatch) -> None:  # type: ignore[no-untyped-def]
    image = np.zeros((48, 64, 3), np.uint8)
    with pytest.raises(ValueError, match="upscale"):
        read_labels(image, image, upscale=0)
    with pytest.raises(ValueError, match="formats"):
        read_labels(image, image, formats=("NoSuchCode",))
    monkeypatch.setitem(sys.modules, "zxingcpp", None)     # import zxingcpp fails
    with pytest.raises(InputError, match=r"zxing-cpp: pip install 'photomodel\[labels\]'"):
        read_labels(image, image)


def _read(text: str) -> LabelRead:
    return LabelRead(text, "QRCode", np.zeros((4, 2)), None)


def test_check_label_prefers_the_label_of_the_answer_and_never_changes_it() -> None:
    asked: list[str] = []

    def verify(name: str):  # type: ignore[no-untyped-def]
        asked.append(name)
        return None, None

    mapping = {"A": "shirt", "B": "towel"}
    assert check_label([], mapping, "shirt", verify) is None
    check = check_label([_read("A"), _read("B")], mapping, "towel", verify)
    assert check is not None and check.read.text == "B" and check.agrees is True
    check = check_label([_read("Z"), _read("B")], mapping, None, verify)
    assert check is not None and check.model == "towel" and check.agrees is False
    check = check_label([_read("Z")], mapping, "shirt", verify)
    assert check is not None and check.model is None and check.agrees is None
    assert asked == ["towel", "towel"]
    assert check.to_json_dict()["corners_cam2"] is None


@pytest.fixture(scope="module")
def labelled_no5() -> tuple[SimulatedScene, GarmentLabel]:
    return _scene("No.5", "QRCode", 3.2, 6)


def test_identify_reports_the_label_and_whether_it_agrees(
        identify_data: IdentifyData, labelled_no5: tuple[SimulatedScene, GarmentLabel]) -> None:
    shot, label = labelled_no5
    config = IdentifyConfig(max_candidates=1)
    right = Identifier(identify_data.models, identify_data.rig, config=config,
                       label_map={label.text: "No.5"})
    answer = right(shot.right_bgr, shot.left_bgr, rng=0)
    doc = json.loads(json.dumps(answer.to_json_dict()))
    assert doc["model"] == "No.5" and doc["found"] is True
    assert doc["label"]["text"] == label.text and doc["label"]["format"] == "QRCode"
    assert doc["label"]["model"] == "No.5" and doc["label"]["agrees"] is True
    assert doc["label"]["model_found"] is True
    assert np.asarray(doc["label"]["corners_cam1"]).shape == (4, 2)

    wrong = Identifier(identify_data.models, identify_data.rig, config=config,
                       label_map={label.text: "No.3"})
    flagged = wrong(shot.right_bgr, shot.left_bgr, rng=0)
    doc = flagged.to_json_dict()
    assert doc["model"] == "No.5" and doc["found"] is True        # never silently resolved
    assert doc["label"]["model"] == "No.3" and doc["label"]["agrees"] is False
    assert doc["label"]["model_found"] is False and doc["label"]["model_score"] is not None

    unread = Identifier(identify_data.models, identify_data.rig, config=config,
                        label_map={label.text: "No.5"}, read_labels=False)
    assert unread(shot.right_bgr, shot.left_bgr, rng=0).to_json_dict()["label"] is None
    assert not Identifier(identify_data.models, identify_data.rig).reads_labels  # no map
    unmapped = Identifier(identify_data.models, identify_data.rig, config=config,
                          read_labels=True)
    doc = unmapped(shot.right_bgr, shot.left_bgr, rng=0).to_json_dict()
    assert doc["model"] == "No.5" and doc["label"]["text"] == label.text
    assert doc["label"]["model"] is None and doc["label"]["agrees"] is None


def test_without_zxing_identify_reads_no_label_and_says_so_once(
        identify_data: IdentifyData, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setitem(sys.modules, "zxingcpp", None)
    with pytest.warns(UserWarning, match="not read without zxing-cpp"):
        identifier = Identifier(identify_data.models, identify_data.rig,
                                label_map={"PM-1": "No.5"})
    assert not identifier.reads_labels
    assert identifier.labels_in(identify_data.scene_right, identify_data.scene_left) == ()
