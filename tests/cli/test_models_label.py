"""``photomodel models label|unlabel|labels``, and labels on the command line: one clear line
and nothing written for a label that names no model, a code taken by another model or a
damaged ``labels.json``; ``simulate --labels`` without zxing-cpp says what to install."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from photomodel.cli import main
from photomodel.library import ModelLibrary
from photomodel.model import PhotoModel


def _run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _one_error(code: int, out: str, err: str, *words: str) -> None:
    assert code == 2 and out == "" and "Traceback" not in err, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("photomodel: error: "), err
    for word in words:
        assert word in lines[0], lines[0]


@pytest.fixture()
def library(tmp_path: Path, plain_case) -> Path:  # type: ignore[no-untyped-def]
    lib = ModelLibrary(tmp_path / "lib", create=True)
    for name in ("shirt", "towel"):
        lib.add_model(PhotoModel(**{**plain_case.built.model.__dict__, "name": name}))
    return lib.root


def _files(root: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(root.iterdir()) if p.is_file()}


def test_labels_are_stored_listed_moved_and_dropped(capsys, library: Path) -> None:  # type: ignore[no-untyped-def]
    code, out, _ = _run(capsys, "models", "label", "--models", library, "shirt", "PM-1")
    assert code == 0 and "'PM-1' names shirt" in out
    _run(capsys, "models", "label", "--models", library, "towel", "0123456789")
    code, out, _ = _run(capsys, "models", "labels", "--models", library, "--json")
    assert json.loads(out)["labels"] == {"PM-1": "shirt", "0123456789": "towel"}
    code, out, _ = _run(capsys, "models", "label", "--models", library, "towel", "PM-1",
                        "--replace")
    assert code == 0 and "(was shirt)" in out
    code, out, _ = _run(capsys, "models", "unlabel", "--models", library, "PM-1")
    assert code == 0 and "named towel" in out
    code, out, _ = _run(capsys, "models", "labels", "--models", library)
    assert code == 0 and "0123456789" in out and "1 label(s)" in out


def test_a_label_that_names_no_model_is_one_line_and_writes_nothing(capsys,  # type: ignore[no-untyped-def]
                                                                    library: Path) -> None:
    before = _files(library)
    _one_error(*_run(capsys, "models", "label", "--models", library, "jeans", "PM-7"),
               "no model named 'jeans'")
    assert _files(library) == before and not (library / "labels.json").exists()


def test_a_code_taken_by_another_model_is_refused_unless_replaced(capsys,  # type: ignore[no-untyped-def]
                                                                  library: Path) -> None:
    _run(capsys, "models", "label", "--models", library, "shirt", "PM-1")
    before = _files(library)
    _one_error(*_run(capsys, "models", "label", "--models", library, "towel", "PM-1"),
               "labels.json", "already names model 'shirt'", "--replace")
    assert _files(library) == before


@pytest.mark.parametrize("argv", [("label", "shirt", "PM-1"), ("unlabel", "PM-1"), ("labels",)])
def test_a_damaged_label_map_is_one_line_naming_it(capsys, library: Path,  # type: ignore[no-untyped-def]
                                                   argv: tuple[str, ...]) -> None:
    (library / "labels.json").write_text('{"format": "photomodel-labels", "labels": ')
    before = _files(library)
    _one_error(*_run(capsys, "models", argv[0], "--models", library, *argv[1:]),
               "labels.json", "not a photomodel label map")
    assert _files(library) == before


def test_bad_codes_and_names_are_one_line(capsys, library: Path) -> None:  # type: ignore[no-untyped-def]
    _one_error(*_run(capsys, "models", "label", "--models", library, "shirt", ""), "CODE")
    _one_error(*_run(capsys, "models", "label", "--models", library, "shirt", "a\nb"), "CODE")
    _one_error(*_run(capsys, "models", "label", "--models", library, "a/b", "PM-1"), "NAME")
    _one_error(*_run(capsys, "models", "unlabel", "--models", library, "PM-404"),
               "no label 'PM-404'")
    assert not (library / "labels.json").exists()


def test_simulate_labels_without_zxing_says_what_to_install(capsys, tmp_path: Path,  # type: ignore[no-untyped-def]
                                                            monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "zxingcpp", None)
    _one_error(*_run(capsys, "simulate", "--out", tmp_path / "ds", "--garments", "No.3",
                     "--labels"), "--labels", "zxing-cpp", "photomodel[labels]")
    assert not (tmp_path / "ds").exists()
    _one_error(*_run(capsys, "simulate", "--out", tmp_path / "seq", "--sequences",
                     "approach", "--labels"), "--labels")


@pytest.fixture(scope="module")
def labelled_pair(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path, str]:
    """A library of No.3, No.5 and No.9, and a pair of No.5 wearing a QR code."""
    pytest.importorskip("zxingcpp")
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "identify"))
    from identify_helpers import make_identify_data

    from photomodel.image import write_image
    from photomodel.sim import (
        catalogue_garment,
        hand_stereo_rig,
        labelled_garment,
        parse_conditions,
        simulate_scene,
    )

    root = tmp_path_factory.mktemp("cli_labels")
    data = make_identify_data(root)
    garment = labelled_garment(catalogue_garment("No.5"), "PM-No.5-0042", "QRCode", 2.8, rng=6)
    shot = simulate_scene(garment, hand_stereo_rig(), parse_conditions("paper"), rng=6)
    write_image(root / "right_label.png", shot.right_bgr)
    write_image(root / "left_label.png", shot.left_bgr)
    return data.library, data.stereo, root, "PM-No.5-0042"


def test_identify_json_carries_the_label_and_the_cross_check(capsys, labelled_pair) -> None:  # type: ignore[no-untyped-def]
    library, stereo, root, code = labelled_pair
    argv = ("identify", "--models", library, "--stereo", stereo, "--right",
            root / "right_label.png", "--left", root / "left_label.png", "--json",
            "--max-candidates", "1")
    _run(capsys, "models", "label", "--models", library, "No.3", code)
    code_, out, err = _run(capsys, *argv)
    assert code_ == 0, err
    doc = json.loads(out)
    assert doc["model"] == "No.5" and doc["label"]["text"] == code
    assert doc["label"]["model"] == "No.3" and doc["label"]["agrees"] is False
    (library / "labels.json").write_text("{")          # damaged: warned, read as no map
    code_, out, err = _run(capsys, *argv)
    assert code_ == 0 and "warning" in err and "labels.json" in err
    assert json.loads(out)["model"] == "No.5" and json.loads(out)["label"] is None
    (library / "labels.json").unlink()
    _run(capsys, "models", "label", "--models", library, "No.5", code)
    code_, out, _ = _run(capsys, *argv)
    label = json.loads(out)["label"]
    assert label["model"] == "No.5" and label["agrees"] is True and label["model_found"]
