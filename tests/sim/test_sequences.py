"""Simulated stereo sequences: the truth layout of docs/contracts.md, byte-identical reruns,
each kind's defining event, motion blur, and ``simulate --sequences`` end to end and on bad
input (one error line, nothing written)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from photomodel.camera import load_stereo
from photomodel.cli import main
from photomodel.model import load_model
from photomodel.sim import (
    SEQUENCE_KINDS,
    SequenceFrame,
    SequenceSettings,
    hand_stereo_rig,
    simulate_sequence,
    write_sequence,
    write_sequences,
)


def _frames(**kw: object) -> list[SequenceFrame]:
    return list(simulate_sequence(SequenceSettings(**kw)))  # type: ignore[arg-type]


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes()
            for p in sorted(root.rglob("*")) if p.is_file()}


def _centre_inside(frames: list[SequenceFrame]) -> None:
    """Where camera 1 sees more than half the garment, its origin projects into the image."""
    cam1 = hand_stereo_rig().cam1
    for frame in frames:
        if frame.visible > 0.5:
            assert frame.T_cam1_model is not None
            u, v = cam1.project(frame.T_cam1_model[:3, 3])
            assert 0 <= u <= cam1.width_px - 1 and 0 <= v <= cam1.height_px - 1, frame.name


def _energy(image: np.ndarray) -> tuple[float, float]:
    """Mean squared grey-level change between neighbours along v (rows) and along u."""
    g = image.astype(np.float64).mean(axis=2)
    return float((np.diff(g, axis=0) ** 2).mean()), float((np.diff(g, axis=1) ** 2).mean())


# --- settings ------------------------------------------------------------------------------


@pytest.mark.parametrize(("kw", "start"), [
    ({"kind": "orbit"}, "kind: "),
    ({"kind": "lost", "fps": 0.0}, "fps: "),
    ({"kind": "lost", "fps": float("nan")}, "fps: "),
    ({"kind": "lost", "seconds": -1.0}, "seconds: "),
    ({"kind": "lost", "seconds": 600.0, "fps": 240.0}, "seconds: "),
    ({"kind": "conveyor", "conveyor_mm_s": 1000.0}, "conveyor_mm_s: "),
    ({"kind": "lost", "exposure_s": 0.1}, "exposure_s: "),
    ({"kind": "lost", "garment": "No.99"}, "garment: "),
    ({"kind": "lost", "garment": "all"}, "garment: "),
    ({"kind": "lost", "seed": -1}, "seed: "),
])
def test_bad_settings_name_the_field(kw: dict[str, object], start: str) -> None:
    with pytest.raises(ValueError) as info:
        SequenceSettings(**kw)  # type: ignore[arg-type]
    assert str(info.value).startswith(start)


def test_frames_and_name() -> None:
    settings = SequenceSettings("approach", fps=29.97, seconds=2.0)
    assert settings.frames == 60 and settings.name == "approach-29.97fps"
    assert SequenceSettings("lost", fps=30.0, seconds=0.01).frames == 1
    assert SEQUENCE_KINDS == ("approach", "conveyor", "occluder", "lost")


# --- the kinds -----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def approach() -> list[SequenceFrame]:
    return _frames(kind="approach", fps=10.0, seconds=0.8, exposure_s=0.0)


def test_approach_descends_to_300_mm_and_the_garment_leaves_the_images(
        approach: list[SequenceFrame]) -> None:
    frames = approach
    assert len(frames) == 8
    distance = np.array([np.linalg.norm(f.T_cam1_model[:3, 3])  # type: ignore[index]
                         for f in frames])
    assert 670.0 < distance[0] < 730.0
    assert 295.0 < distance[-1] < 330.0
    assert np.all(np.diff(distance) < 1.0)  # monotonic, but for the < 0.5 mm vibration
    height = -np.asarray(frames[0].info["T_table_cam1"])[2, 3]
    assert height == pytest.approx(685.0, abs=1.0)
    assert frames[0].visible == 1.0 and frames[-1].visible < 1.0
    _centre_inside(frames)


def test_approach_vibrates_while_the_garment_lies_still(approach: list[SequenceFrame]) -> None:
    poses = [np.asarray(f.info["T_table_model"]) for f in approach]
    assert all(np.array_equal(p, poses[0]) for p in poses)
    # Camera 1 = start + s(t) * travel + vibration: a least-squares fit of the first two
    # leaves the vibration (0.3-0.5 mm amplitude).
    t = np.array([f.t_s for f in approach]) / 0.8
    s = t ** 3 * (10 - 15 * t + 6 * t ** 2)
    position = np.array([np.asarray(f.info["T_table_cam1"])[:3, 3] for f in approach])
    design = np.column_stack([np.ones_like(s), s])
    fit, *_ = np.linalg.lstsq(design, position, rcond=None)
    residual = np.linalg.norm(position - design @ fit, axis=1)
    assert 0.05 < float(np.sqrt(np.mean(residual ** 2))) < 0.5
    assert np.linalg.norm(fit[1]) > 380.0  # the descent: 385 mm plus the garment's offset


def test_conveyor_moves_the_garment_by_speed_over_fps_with_blur_along_the_motion() -> None:
    blurred = _frames(kind="conveyor", fps=30.0, seconds=0.2, conveyor_mm_s=300.0)
    sharp = _frames(kind="conveyor", fps=30.0, seconds=0.2, conveyor_mm_s=300.0,
                    exposure_s=0.0)
    positions = np.array([f.T_cam1_model[:3, 3] for f in blurred])  # type: ignore[index]
    steps = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    np.testing.assert_allclose(steps, 300.0 / 30.0, atol=1e-6)
    for a, b in zip(blurred, sharp, strict=True):
        np.testing.assert_array_equal(a.T_cam1_model, b.T_cam1_model)  # type: ignore[arg-type]
        assert a.info["motion_blur_px"] == pytest.approx(300.0 * 0.004 * 800.0 / 690.0,
                                                         rel=0.2)
    # The belt runs along the table's y, about camera 1's image rows (v): blur softens the
    # image's changes along v, not along u (the noise is the same in both renderings).
    cam1 = hand_stereo_rig().cam1
    for a, b in zip(blurred, sharp, strict=True):
        u, v = np.rint(cam1.project(a.T_cam1_model[:3, 3])).astype(int)  # type: ignore[index]
        window = (slice(max(v - 60, 0), v + 60), slice(max(u - 60, 0), u + 60))
        (bv, bu), (sv, su) = _energy(a.right_bgr[window]), _energy(b.right_bgr[window])
        assert bv / sv < bu / su - 0.05, (bv / sv, bu / su)
    _centre_inside(blurred)


def test_conveyor_garment_outside_both_images_keeps_its_pose_with_visible_0() -> None:
    frames = _frames(kind="conveyor", fps=2.0, seconds=4.0, conveyor_mm_s=300.0,
                     exposure_s=0.0)
    assert frames[0].visible == 0.0 and frames[0].info["visible_cam2"] == 0.0
    assert frames[0].T_cam1_model is not None
    assert max(f.visible for f in frames) == 1.0


def test_occluder_hides_part_of_the_garment_then_leaves() -> None:
    frames = _frames(kind="occluder", fps=15.0, seconds=1.0)
    visible = np.array([f.visible for f in frames])
    assert visible[0] == 1.0 and visible[-1] == 1.0
    assert visible.min() < 0.95
    dip = int(np.argmin(visible))
    assert 0 < dip < len(frames) - 1
    poses = [f.T_cam1_model for f in frames]
    assert all(np.array_equal(p, poses[0]) for p in poses)  # type: ignore[arg-type]
    assert max(f.info["motion_blur_px"] for f in frames) > 1.0  # the gripper is blurred
    _centre_inside(frames)


def test_lost_garment_is_absent_then_lies_elsewhere() -> None:
    frames = _frames(kind="lost", fps=10.0, seconds=1.0)
    absent = [f for f in frames if f.T_cam1_model is None]
    assert [f.index for f in absent] == [4, 5, 6]
    assert all(f.visible == 0.0 and f.truth()["T_cam1_model"] is None for f in absent)
    first, last = frames[0].T_cam1_model, frames[-1].T_cam1_model
    assert first is not None and last is not None
    assert frames[0].visible == 1.0 and frames[-1].visible == 1.0
    assert np.linalg.norm(last[:3, 3] - first[:3, 3]) >= 50.0
    assert np.array_equal(frames[0].T_cam1_model, frames[1].T_cam1_model)  # type: ignore[arg-type]
    _centre_inside(frames)


def test_rates_share_one_motion() -> None:
    """A kind's 30 and 60 fps sequences show the same motion (the noise differs)."""
    slow = _frames(kind="conveyor", fps=30.0, seconds=0.1, exposure_s=0.0)
    fast = _frames(kind="conveyor", fps=60.0, seconds=0.1, exposure_s=0.0)
    for k, frame in enumerate(slow):
        assert fast[2 * k].t_s == pytest.approx(frame.t_s)
        np.testing.assert_allclose(fast[2 * k].T_cam1_model, frame.T_cam1_model, atol=1e-9)  # type: ignore[arg-type]


# --- files ---------------------------------------------------------------------------------


def test_write_sequence_layout_truth_and_byte_identical_reruns(tmp_path: Path) -> None:
    settings = SequenceSettings("lost", fps=10.0, seconds=0.5, seed=4)
    calls: list[tuple[int, int, str]] = []
    write_sequence(tmp_path / "a", settings, progress=lambda *c: calls.append(c))
    write_sequence(tmp_path / "b", settings)
    write_sequence(tmp_path / "c", SequenceSettings("lost", fps=10.0, seconds=0.5, seed=5))
    a, b, c = _files(tmp_path / "a"), _files(tmp_path / "b"), _files(tmp_path / "c")
    names = [f"{k:06d}" for k in range(5)]
    assert set(a) == {"truth.json"} | {f"{n}/{s}.png" for n in names for s in ("right", "left")}
    assert a == b
    assert all(a[p] != c[p] for p in a if p.endswith(".png"))
    assert [d for d, _, _ in calls] == [1, 2, 3, 4, 5] and calls[-1][1] == 5
    truth = json.loads(a["truth.json"])
    assert truth["model"] == "No.1" and truth["kind"] == "lost" and truth["fps"] == 10.0
    assert list(truth["frames"]) == names == sorted(truth["frames"])
    for k, name in enumerate(names):
        entry = truth["frames"][name]
        assert entry["t_s"] == pytest.approx(k / 10.0)
        assert 0.0 <= entry["visible"] <= 1.0
        T = entry["T_cam1_model"]
        assert T is None or np.asarray(T).shape == (4, 4)
        assert np.asarray(entry["T_table_cam1"]).shape == (4, 4)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "b", "c"]  # no partials


def test_write_sequence_refuses_a_non_empty_directory(tmp_path: Path) -> None:
    from photomodel.errors import InputError

    settings = SequenceSettings("occluder", fps=5.0, seconds=0.2)
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("keep")
    with pytest.raises(InputError, match="not a sequence"):
        write_sequence(tmp_path / "other", settings, overwrite=True)
    write_sequence(tmp_path / "seq", settings)
    with pytest.raises(InputError, match="--force"):
        write_sequence(tmp_path / "seq", settings)
    write_sequence(tmp_path / "seq", settings, overwrite=True)
    assert (tmp_path / "other" / "notes.txt").read_text() == "keep"


def test_write_sequences_has_what_a_tracker_needs(tmp_path: Path) -> None:
    summary = write_sequences(tmp_path / "out", ["occluder"], (5.0, 10.0), seconds=0.2,
                              garment="No.3", seed=2)
    out = tmp_path / "out"
    assert summary.sequences == ("occluder-5fps", "occluder-10fps") and summary.frames == 3
    assert load_stereo(summary.stereo).cam1.width_px == 640
    model = load_model(summary.model)
    assert model.name == "No.3" and summary.model == out / "models" / "No.3.npz"
    manifest = json.loads((out / "sequences.json").read_text())
    assert manifest["garment"] == "No.3" and set(manifest["sequences"]) == set(summary.sequences)
    for name in summary.sequences:
        truth = json.loads((out / name / "truth.json").read_text())
        assert truth["model"] == model.name
    with pytest.raises(ValueError, match="^kinds: "):
        write_sequences(tmp_path / "bad", ["orbit"])
    assert not (tmp_path / "bad").exists()


# --- command line --------------------------------------------------------------------------


def _run(capsys: pytest.CaptureFixture[str], argv: list[object]) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_cli_writes_sequences(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "seq"
    code, stdout, err = _run(capsys, ["simulate", "--out", out, "--sequences", "lost,conveyor",
                                      "--fps", "5,10", "--seconds", "0.2", "--seed", "3",
                                      "--conveyor-mm-s", "250"])
    assert code == 0, err
    assert "4 sequence(s)" in stdout and "models/No.1.npz" in stdout
    names = {"lost-5fps", "lost-10fps", "conveyor-5fps", "conveyor-10fps"}
    assert {p.name for p in out.iterdir()} == names | {"stereo.yaml", "models", "sequences.json"}
    truth = json.loads((out / "conveyor-10fps" / "truth.json").read_text())
    assert truth["events"]["conveyor_mm_s"] == 250.0 and truth["kind"] == "conveyor"
    assert sorted(p.name for p in (out / "conveyor-10fps").iterdir()) == [
        "000000", "000001", "truth.json"]
    before = _files(out)
    code, _, err = _run(capsys, ["simulate", "--out", out, "--sequences", "lost,conveyor",
                                 "--fps", "5,10", "--seconds", "0.2", "--seed", "3",
                                 "--conveyor-mm-s", "250", "--force"])
    assert code == 0, err
    after = _files(out)
    assert {p: b for p, b in after.items() if p.endswith(".png")} == {
        p: b for p, b in before.items() if p.endswith(".png")}


@pytest.mark.parametrize(("args", "mentions"), [
    (["--sequences", "orbit"], ["--sequences", "orbit", "approach"]),
    (["--sequences", "lost", "--fps", "0"], ["--fps", "greater than 0"]),
    (["--sequences", "lost", "--fps", "-30"], ["--fps"]),
    (["--sequences", "lost", "--fps", "thirty"], ["--fps", "thirty"]),
    (["--sequences", "lost", "--fps", ","], ["--fps"]),
    (["--sequences", "lost", "--seconds", "0"], ["--seconds"]),
    (["--sequences", "lost", "--seconds", "100", "--fps", "200"], ["--seconds", "frames"]),
    (["--sequences", "conveyor", "--conveyor-mm-s", "50"], ["--conveyor-mm-s", "100"]),
    (["--sequences", "lost", "--garments", "No.99"], ["--garments", "No.99"]),
    (["--sequences", "lost", "--garments", "No.1,No.3"], ["--garments", "one garment"]),
    (["--sequences", "lost", "--scenes", "3"], ["--scenes", "--sequences"]),
    (["--fps", "60"], ["--fps", "--sequences"]),
])
def test_cli_bad_input_is_one_line_and_writes_nothing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str],
        mentions: list[str]) -> None:
    code, stdout, err = _run(capsys, ["simulate", "--out", tmp_path / "out", *args])
    assert code == 2 and stdout == ""
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("photomodel: error: "), err
    for text in mentions:
        assert text in lines[0], (text, lines[0])
    assert list(tmp_path.iterdir()) == []


def test_cli_refuses_an_existing_out_without_force(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("keep")
    for extra in ([], ["--force"]):
        code, _, err = _run(capsys, ["simulate", "--out", out, "--sequences", "lost",
                                     "--seconds", "0.1", *extra])
        assert code == 2 and err.count("\n") == 1 and str(out) in err, err
    assert [p.name for p in tmp_path.iterdir()] == ["out"]
    assert [p.name for p in out.iterdir()] == ["notes.txt"]
