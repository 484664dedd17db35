"""Tracker: detection on the first frame, tracking after it, losses, bad frames, the CLI."""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import cv2
import numpy as np
import pytest

from photomodel.camera import save_stereo
from photomodel.cli import main
from photomodel.errors import InputError
from photomodel.experiments import ExperimentConfig, Trial, trial_inputs
from photomodel.model import save_model
from photomodel.track import Tracker, TrackerConfig, TrackResult


@lru_cache(maxsize=2)
def _case(garment: str = "No.6", condition: str = "paper"):
    config = ExperimentConfig(garments=(garment,), conditions=(condition,), trials=1, seed=0)
    return trial_inputs(config, Trial(f"{condition}_{garment}_0000", garment, condition, 0))


def _error_mm(result: TrackResult, T: np.ndarray) -> float:
    return float(np.linalg.norm(result.T_cam1_model[:3, 3] - T[:3, 3]))


def test_the_first_frame_is_detected_the_next_ones_tracked() -> None:
    model, rig, right, left, T_true, _ = _case()
    track = Tracker(model, rig)
    first = track(right, left, t_s=0.0, rng=0)
    assert first.mode == "detect" and first.found and first.frame == 0
    assert _error_mm(first, T_true) < 1.0 and first.visible == pytest.approx(1.0)
    for k in range(1, 4):
        r = track(right, left, t_s=k / 30)
        assert r.mode == "track" and r.found and r.frame == k and r.t_s == pytest.approx(k / 30)
        assert _error_mm(r, T_true) < 1.0
        assert r.search.evaluations < first.search.evaluations / 4
    doc = r.to_json_dict()
    assert {"frame", "found", "mode", "T_cam1_model", "score", "seconds", "t_s",
            "visible"} <= set(doc)
    assert doc["mode"] == "track" and len(doc["T_cam1_model"]) == 4
    track.reset()
    assert track(right, left, rng=0).mode == "detect"


def test_an_empty_table_is_lost_without_a_pose_and_found_again() -> None:
    model, rig, right, left, T_true, _ = _case()
    empty_r, empty_l = _empty(right, left)
    track = Tracker(model, rig)
    assert track(right, left, t_s=0.0, rng=0).mode == "detect"
    gone = track(empty_r, empty_l, t_s=1 / 30, rng=0)
    assert gone.mode == "lost" and not gone.found and gone.note
    doc = gone.to_json_dict()
    assert doc["T_cam1_model"] is None and doc["position_mm"] is None and doc["found"] is False
    back = track(right, left, t_s=2 / 30, rng=0)
    assert back.mode == "detect" and back.found and _error_mm(back, T_true) < 1.0


def _empty(right: np.ndarray, left: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The same images with the garment painted over by the table's colour."""
    out = []
    for image in (right, left):
        table = np.median(image[:20].reshape(-1, 3), axis=0).astype(np.uint8)
        out.append(np.broadcast_to(table, image.shape).copy())
    return out[0], out[1]


def test_a_given_prediction_replaces_the_motion_model_s() -> None:
    """A moving hand tells the tracker where the garment should be (ego-motion): after the
    camera jumped 35 mm sideways between two frames, the frame is tracked from the given pose
    to the truth."""
    from photomodel.geometry import invert_transform, make_transform
    from photomodel.sim import ConveyorView, hand_stereo_rig, hand_table_pose, station_model

    rig = hand_stereo_rig()
    view = ConveyorView("No.6", speed_mm_s=0.0, seed=0, key=("predicted",), rig=rig)
    T_table_cam1 = invert_transform(hand_table_pose(rig))
    moved = make_transform(np.eye(3), [35.0, -20.0, 0.0]) @ T_table_cam1
    a = view.frame(0, 0.0, lambda t: T_table_cam1)
    b = view.frame(1, 1 / 30, lambda t: moved)
    track = Tracker(station_model("No.6", 0), rig)
    assert track(a.right_bgr, a.left_bgr, t_s=0.0, rng=0).found
    assert b.T_cam1_model is not None
    r = track(b.right_bgr, b.left_bgr, t_s=1 / 30, predicted=b.T_cam1_model)
    assert r.found and r.mode == "track", r.note
    assert _error_mm(r, b.T_cam1_model) < 1.5
    with pytest.raises(InputError, match="predicted"):
        track(b.right_bgr, b.left_bgr, t_s=2 / 30, predicted=np.eye(3))
    bad = np.eye(4)
    bad[0, 0] = 2.0
    with pytest.raises(InputError, match="predicted: its rotation part"):
        track(b.right_bgr, b.left_bgr, t_s=3 / 30, predicted=bad)


def test_a_timestamp_that_goes_back_restarts_with_a_note() -> None:
    model, rig, right, left, _, _ = _case()
    track = Tracker(model, rig)
    track(right, left, t_s=1.0, rng=0)
    assert track(right, left, t_s=1.1).mode == "track"
    again = track(right, left, t_s=0.5, rng=0)
    assert again.mode == "detect" and again.note and "does not advance" in again.note
    with pytest.raises(InputError, match="t_s"):
        track(right, left, t_s=float("nan"))


def test_a_frame_of_another_size_is_refused_and_tracking_goes_on() -> None:
    model, rig, right, left, _, _ = _case()
    track = Tracker(model, rig)
    track(right, left, t_s=0.0, rng=0)
    with pytest.raises(InputError, match="right image"):
        track(right[:-8], left, t_s=1 / 30)
    assert track(right, left, t_s=2 / 30).mode == "track"


def test_config_validation() -> None:
    with pytest.raises(ValueError, match="fps"):
        TrackerConfig(fps=0.0)
    with pytest.raises(ValueError, match="levels"):
        TrackerConfig(levels=(0, 1))
    with pytest.raises(ValueError, match="near_z_mm"):
        TrackerConfig(near_z_mm=(600.0, 300.0))


def _sequence(root: Path, frames: int) -> tuple[Path, Path, Path]:
    model, rig, right, left, _, _ = _case()
    seq = root / "seq"
    for k in range(frames):
        (seq / f"{k:06d}").mkdir(parents=True)
        cv2.imwrite(str(seq / f"{k:06d}" / "right.png"), right)
        cv2.imwrite(str(seq / f"{k:06d}" / "left.png"), left)
    (seq / "truth.json").write_text(json.dumps(
        {"model": model.name, "fps": 60, "kind": "still",
         "frames": {f"{k:06d}": {"T_cam1_model": None, "visible": 1.0, "t_s": k / 60}
                    for k in range(frames)}}))
    save_model(model, root / "m.npz")
    save_stereo(root / "stereo.yaml", rig)
    return seq, root / "m.npz", root / "stereo.yaml"


def test_the_track_command_prints_one_json_line_per_frame(tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]
                                                          ) -> None:
    seq, model, stereo = _sequence(tmp_path, 3)
    (seq / "000001" / "left.png").write_bytes(b"not a png")
    code = main(["track", "--model", str(model), "--stereo", str(stereo), "--frames", str(seq),
                 "--json"])
    out, err = capsys.readouterr()
    lines = [json.loads(line) for line in out.splitlines()]
    assert code == 1 and [d["name"] for d in lines] == ["000000", "000002"]
    assert [d["mode"] for d in lines] == ["detect", "track"]
    assert lines[1]["t_s"] == pytest.approx(2 / 60)       # from truth.json
    assert err.count("\n") == 1 and "frame 000001" in err and "left.png" in err
    code = main(["track", "--model", str(model), "--stereo", str(stereo), "--frames",
                 str(tmp_path / "nothing")])
    assert code == 2 and "expected a sequence folder" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert main(["track", "--model", str(model), "--stereo", str(stereo), "--frames",
                 str(tmp_path / "empty")]) == 2
    assert "no frames" in capsys.readouterr().err
    assert main(["track", "--model", str(model), "--stereo", str(stereo), "--frames",
                 str(seq), "--fps", "0"]) == 2
    assert "--fps" in capsys.readouterr().err
