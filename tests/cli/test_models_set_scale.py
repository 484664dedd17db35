"""``photomodel models set-scale``: a model of unknown scale stored at a measured scale (from a
locate answer or a factor), sampled anew; one error line and nothing changed otherwise."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import pytest

from photomodel.cli import main
from photomodel.library import ModelLibrary
from photomodel.model import build_unknown_scale, load_model, scale_known
from photomodel.sim import catalogue_garment, model_station_camera, render_model_photos


@pytest.fixture(scope="module")
def nominal():  # type: ignore[no-untyped-def]
    photo, _ = render_model_photos(catalogue_garment("No.2"), model_station_camera(), rng=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return build_unknown_scale(photo, name="No.2").model


@pytest.fixture
def library(nominal, tmp_path: Path) -> Path:  # type: ignore[no-untyped-def]
    root = tmp_path / "lib"
    ModelLibrary(root, create=True).add_model(nominal)
    return root


def _file(library: Path) -> bytes:
    entry = ModelLibrary(library).entry("No.2")
    return (library / entry.file).read_bytes()


def test_the_scale_of_a_found_locate_is_stored(library: Path, tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    result = tmp_path / "r.json"
    result.write_text(json.dumps({"model": "No.2", "found": True, "scale": 0.5657}))
    assert main(["models", "set-scale", "--models", str(library), "No.2", "--from-result",
                 str(result)]) == 0
    assert "0.56570 mm per nominal mm stored" in capsys.readouterr().out
    entry = ModelLibrary(library).entry("No.2")
    model = load_model(library / entry.file)
    assert scale_known(model) and model.meta["scale"]["factor"] == pytest.approx(0.5657)
    assert entry.size_mm[1] == pytest.approx(200, abs=5)       # the trousers, 200 mm long
    assert 2500 < model.n_in < 4000                             # 3 real mm apart


@pytest.mark.parametrize("answer, text", [
    ({"model": "No.3", "found": True, "scale": 0.5}, "no locate answer of model 'No.2'"),
    ({"model": "No.2", "found": True}, "has no measured scale"),
    ({"model": "No.2", "found": False, "scale": 0.5}, "scale is not confirmed"),
    ("not json", "not a locate --json answer"),
])
def test_a_result_that_cannot_confirm_the_scale_is_refused(
        library: Path, tmp_path: Path, capsys, answer, text: str) -> None:  # type: ignore[no-untyped-def]
    before = _file(library)
    result = tmp_path / "r.json"
    result.write_text(answer if isinstance(answer, str) else json.dumps(answer))
    assert main(["models", "set-scale", "--models", str(library), "No.2", "--from-result",
                 str(result)]) == 2
    err = capsys.readouterr().err.strip()
    assert text in err and len(err.splitlines()) == 1 and "Traceback" not in err
    assert _file(library) == before


def test_a_bad_factor_a_known_scale_and_an_unknown_name_are_refused(
        library: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    args = ["models", "set-scale", "--models", str(library)]
    assert main([*args, "No.2", "--factor", "100"]) == 2
    assert "--factor: expected a factor from 0.05 to 20" in capsys.readouterr().err
    assert main([*args, "No.9", "--factor", "0.5"]) == 2
    assert "no model named 'No.9'" in capsys.readouterr().err
    assert main([*args, "No.2", "--factor", "0.5"]) == 0
    capsys.readouterr()
    assert main([*args, "No.2", "--factor", "0.5"]) == 2
    assert "has a known scale already" in capsys.readouterr().err
