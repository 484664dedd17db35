"""write_dataset: the dataset layout of docs/contracts.md, byte-identical reruns, additive
seeds, clean failures."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from photomodel.camera import load_camera, load_distance_mm, load_stereo
from photomodel.errors import InputError
from photomodel.sim import (
    Garment,
    PlaneTexture,
    hand_stereo_rig,
    model_station_camera,
    write_dataset,
)

GARMENTS = ["No.1", "No.3"]
CONDITIONS = ["paper", "wrinkles+distractors", "no-target"]
SCENE_IDS = {"paper_No.1_0000", "paper_No.3_0000", "wrinkles+distractors_No.1_0000",
             "wrinkles+distractors_No.3_0000", "no-target_0000"}


def _files(root: Path) -> dict[str, bytes]:
    """Every file under ``root`` by its relative path (POSIX), with its bytes."""
    return {p.relative_to(root).as_posix(): p.read_bytes()
            for p in sorted(root.rglob("*")) if p.is_file()}


def _leftovers(parent: Path) -> list[str]:
    return sorted(p.name for p in parent.iterdir() if ".partial-" in p.name)


@pytest.fixture(scope="module")
def datasets(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The main dataset twice (same seed), a subset of it, and the subset with another seed."""
    root = tmp_path_factory.mktemp("datasets")
    calls: list[tuple[int, int, str]] = []
    write_dataset(root / "a", GARMENTS, CONDITIONS, scenes=1, seed=7,
                  progress=lambda done, total, label: calls.append((done, total, label)))
    (root / "a.progress.json").write_text(json.dumps(calls))
    write_dataset(root / "b", GARMENTS, CONDITIONS, scenes=1, seed=7)
    write_dataset(root / "subset", ["No.3"], ["paper", "no-target"], scenes=1, seed=7)
    write_dataset(root / "other_seed", ["No.3"], ["paper", "no-target"], scenes=1, seed=8)
    return {name: root / name for name in ("a", "b", "subset", "other_seed")}


def test_layout_of_design_md(datasets: dict[str, Path]) -> None:
    root = datasets["a"]
    files = set(_files(root))
    expected = {"stereo.yaml", "model_camera.yaml", "truth.json", "dataset.json"}
    expected |= {f"models/{g}/{f}" for g in GARMENTS for f in ("photo.bmp", "background.bmp")}
    expected |= {f"scenes/{s}/{f}" for s in SCENE_IDS for f in ("right.png", "left.png")}
    assert files == expected
    truth = json.loads((root / "truth.json").read_text())
    assert set(truth) == {p.name for p in (root / "scenes").iterdir()} == SCENE_IDS
    for scene_id, entry in truth.items():
        assert entry["condition"] == scene_id.rsplit("_", 2 if entry["model"] else 1)[0]
        if scene_id.startswith("no-target"):
            assert entry["model"] is None and entry["T_cam1_model"] is None
            continue
        assert entry["model"] == scene_id.split("_")[1]
        T = np.array(entry["T_cam1_model"])
        assert T.shape == (4, 4)
        np.testing.assert_allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-9)
        assert np.linalg.det(T[:3, :3]) == pytest.approx(1.0)
        np.testing.assert_array_equal(T[3], [0, 0, 0, 1])
        assert 500 < T[2, 3] < 900  # on the table, about 685 mm from the rig
        assert entry["visible_fraction"] == pytest.approx([1.0, 1.0], abs=0.03)
    assert truth["wrinkles+distractors_No.1_0000"]["wrinkle_height_mm"] == 8.0
    assert len(truth["no-target_0000"]["distractors"]) >= 1
    manifest = json.loads((root / "dataset.json").read_text())
    assert manifest["seed"] == 7 and set(manifest["garments"]) == set(GARMENTS)
    assert set(manifest["conditions"]) == set(CONDITIONS)


def test_calibration_files_load_and_match_the_images(datasets: dict[str, Path]) -> None:
    root = datasets["a"]
    rig = load_stereo(root / "stereo.yaml")
    reference = hand_stereo_rig()
    for cam, ref in ((rig.cam1, reference.cam1), (rig.cam2, reference.cam2)):
        np.testing.assert_allclose(cam.K, ref.K)
        np.testing.assert_allclose(cam.dist, ref.dist)
        assert (cam.width_px, cam.height_px) == (640, 480)
    np.testing.assert_allclose(rig.T_cam2_cam1, reference.T_cam2_cam1, atol=1e-9)
    camera = load_camera(root / "model_camera.yaml")
    np.testing.assert_allclose(camera.K, model_station_camera().K)
    assert load_distance_mm(root / "model_camera.yaml") == 400.0
    for scene in (root / "scenes").iterdir():
        for name in ("right.png", "left.png"):
            image = cv2.imread(str(scene / name), cv2.IMREAD_UNCHANGED)
            assert image.shape == (480, 640, 3) and image.dtype == np.uint8
    for garment in GARMENTS:
        for name in ("photo.bmp", "background.bmp"):
            image = cv2.imread(str(root / "models" / garment / name), cv2.IMREAD_UNCHANGED)
            assert image.shape == (camera.height_px, camera.width_px, 3)


def test_progress_counts_every_image(datasets: dict[str, Path]) -> None:
    calls = json.loads((datasets["a"].parent / "a.progress.json").read_text())
    total = len(GARMENTS) + len(SCENE_IDS)
    assert [c[0] for c in calls] == list(range(1, total + 1))
    assert all(c[1] == total for c in calls)
    assert calls[0][2] == "model No.1" and calls[-1][2] == "scene no-target_0000"


def test_same_seed_gives_byte_identical_files(datasets: dict[str, Path]) -> None:
    a, b = _files(datasets["a"]), _files(datasets["b"])
    assert set(a) == set(b)
    differing = [name for name in a if a[name] != b[name]]
    assert differing == []


def test_fewer_garments_and_conditions_leave_the_common_files_identical(
        datasets: dict[str, Path]) -> None:
    full, subset = _files(datasets["a"]), _files(datasets["subset"])
    assert set(subset) < set(full)
    common = [name for name in subset if name not in ("truth.json", "dataset.json")]
    assert "scenes/paper_No.3_0000/right.png" in common and "models/No.3/photo.bmp" in common
    assert [name for name in common if subset[name] != full[name]] == []
    truth_full = json.loads(full["truth.json"])
    truth_subset = json.loads(subset["truth.json"])
    assert set(truth_subset) == {"paper_No.3_0000", "no-target_0000"}
    for scene_id, entry in truth_subset.items():
        assert entry == truth_full[scene_id]


def test_another_seed_gives_other_images_and_poses(datasets: dict[str, Path]) -> None:
    seven, eight = _files(datasets["subset"]), _files(datasets["other_seed"])
    assert set(seven) == set(eight)
    for name in ("scenes/paper_No.3_0000/right.png", "scenes/paper_No.3_0000/left.png",
                 "scenes/no-target_0000/right.png", "models/No.3/photo.bmp"):
        assert seven[name] != eight[name], name
    # The calibration does not depend on the seed.
    assert seven["stereo.yaml"] == eight["stereo.yaml"]
    T7 = json.loads(seven["truth.json"])["paper_No.3_0000"]["T_cam1_model"]
    T8 = json.loads(eight["truth.json"])["paper_No.3_0000"]["T_cam1_model"]
    assert not np.allclose(T7, T8)


# --- errors ----------------------------------------------------------------------------------


def test_existing_non_empty_out_is_refused_and_left_alone(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("precious")
    with pytest.raises(InputError, match="already exists"):
        write_dataset(out, ["No.3"], ["paper"])
    assert _files(out) == {"keep.txt": b"precious"}
    assert _leftovers(tmp_path) == []
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    with pytest.raises(InputError, match="a_file"):
        write_dataset(a_file, ["No.3"], ["paper"])
    assert a_file.read_text() == "x"


def test_overwrite_replaces_and_an_empty_out_is_filled(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.txt").write_text("old")
    with pytest.raises(InputError, match="not a dataset"):   # not one simulate wrote
        write_dataset(out, ["No.3"], ["no-target"], overwrite=True)
    assert _files(out) == {"old.txt": b"old"}
    (out / "dataset.json").write_text('{"format": "photomodel-dataset"}')
    summary = write_dataset(out, ["No.3"], ["no-target"], overwrite=True)
    assert summary.scenes == ("no-target_0000",) and summary.models == ("No.3",)
    assert not (out / "old.txt").exists() and (out / "truth.json").is_file()
    empty = tmp_path / "empty"
    empty.mkdir()
    write_dataset(empty, ["No.3"], ["no-target"])
    assert (empty / "scenes" / "no-target_0000" / "left.png").is_file()
    assert _leftovers(tmp_path) == []


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"garments": ["No.3", "No.99"]}, "No.99"),
    ({"conditions": ["paper", "wood+mud"]}, "mud"),
    ({"conditions": ["paper", "wide-lens"]}, "lens"),
    ({"conditions": ["no-distortion", "paper"]}, "lens"),
    ({"conditions": []}, "conditions"),
    ({"scenes": 0}, "scenes"),
    ({"garments": [], "conditions": ["paper"]}, "garments"),
])
def test_bad_arguments_fail_before_anything_is_written(tmp_path: Path, kwargs: dict,
                                                       match: str) -> None:
    args = {"garments": ["No.3"], "conditions": ["paper"], **kwargs}
    out = tmp_path / "out"
    with pytest.raises(ValueError, match=match):
        write_dataset(out, **args)
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def _user_garment(size_mm: float, name: str = "mine") -> Garment:
    n = round(size_mm)
    texture = PlaneTexture(np.full((n, n, 3), 200, np.uint8), np.ones((n, n), np.float32), 1.0,
                           np.array([(n - 1) / 2, (n - 1) / 2]))
    return Garment(name, texture, (float(n), float(n)))


@pytest.mark.parametrize("name", ["a/b", "..", "", "x:y"])
def test_extra_garment_names_must_be_directory_names(tmp_path: Path, name: str) -> None:
    with pytest.raises(ValueError, match="name"):
        write_dataset(tmp_path / "out", [], ["paper"], extra_garments={name: _user_garment(50)})
    assert list(tmp_path.iterdir()) == []


def test_extra_garment_may_not_reuse_a_catalogue_name(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="No.3"):
        write_dataset(tmp_path / "out", ["No.3"], ["paper"],
                      extra_garments={"No.3": _user_garment(50)})
    assert list(tmp_path.iterdir()) == []


def test_failure_while_rendering_leaves_nothing_behind(tmp_path: Path) -> None:
    """A garment too big for the cameras fails mid-way: the hidden build dir is removed."""
    out = tmp_path / "out"
    with pytest.raises(ValueError, match="does not fit"):
        write_dataset(out, [], ["paper"], extra_garments={"huge": _user_garment(700)})
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_failure_leaves_no_parent_directories_it_created(tmp_path: Path) -> None:
    """Nothing half-written (docs/contracts.md, "Command line", errors) includes the missing
    parents of ``out``: write_dataset creates them for its hidden build directory
    (``tmp.mkdir(parents=True)``) and, on a failure, removes only the build directory, leaving
    ``new/deeper/`` behind."""
    with pytest.raises(ValueError, match="does not fit"):
        write_dataset(tmp_path / "new" / "deeper" / "out", [], ["paper"],
                      extra_garments={"huge": _user_garment(700)})
    assert list(tmp_path.iterdir()) == []
