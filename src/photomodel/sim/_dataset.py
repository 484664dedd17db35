"""A simulated dataset directory, as ``photomodel simulate`` writes it (docs/contracts.md).

::

    DIR/stereo.yaml                    stereo calibration (camera 1 = reference)
    DIR/model_camera.yaml              model-station camera (with distance_mm)
    DIR/models/<name>/photo.bmp        the garment on the green plane
    DIR/models/<name>/background.bmp   the plane alone
    DIR/scenes/<id>/right.png          camera 1
    DIR/scenes/<id>/left.png           camera 2
    DIR/truth.json                     {"<id>": {"model": ..., "T_cam1_model": ..., ...}}
    DIR/dataset.json                   how it was made: seed, garments, conditions, versions

Every image has its own seed, derived from the dataset's seed and the names (condition,
garment, index) of what it shows, so the same seed gives byte-identical files, and adding a
garment or a condition leaves the other scenes unchanged. The directory is built beside its
final place and moved there only when complete.
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
import shutil
import zlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from photomodel.camera import save_camera, save_stereo
from photomodel.errors import InputError
from photomodel.image import write_image
from photomodel.sim._catalogue import catalogue_garment, garment_names
from photomodel.sim._conditions import Conditions, parse_conditions
from photomodel.sim._garments import Garment
from photomodel.sim._rigs import MODEL_DISTANCE_MM, hand_stereo_rig, model_station_camera
from photomodel.sim._scenes import render_model_photos, simulate_scene

__all__ = [
    "DATASET_FORMAT_VERSION",
    "DatasetSummary",
    "dumps_json",
    "scene_rng",
    "write_dataset",
]

DATASET_FORMAT_VERSION = 1


def _key(text: str) -> int:
    return zlib.crc32(text.encode("utf-8"))


def scene_rng(seed: int, *names: str | int) -> np.random.Generator:
    """The generator of one image of a dataset: seeded by the dataset's seed and its names."""
    keys = [int(seed)] + [n if isinstance(n, int) else _key(n) for n in names]
    return np.random.default_rng(keys)


@dataclass(frozen=True)
class DatasetSummary:
    """What :func:`write_dataset` wrote.

    Parameters
    ----------
    out : Path
        The dataset directory.
    models : tuple of str
        Garment names (``models/<name>/``).
    scenes : tuple of str
        Scene ids (``scenes/<id>/``), in the order of ``truth.json``.
    """

    out: Path
    models: tuple[str, ...]
    scenes: tuple[str, ...]


def _check_name(name: str) -> None:
    if not name or name in (".", "..") or any(c in name for c in '/\\:*?"<>|'):
        raise ValueError(f"garment name {name!r} cannot be a directory name")


def write_dataset(
    out: str | os.PathLike[str],
    garments: Sequence[str] | None = None,
    conditions: Sequence[str] = ("paper",),
    scenes: int = 1,
    seed: int = 0,
    *,
    extra_garments: Mapping[str, Garment] | None = None,
    overwrite: bool = False,
    progress: Callable[[int, int, str], None] | None = None,
) -> DatasetSummary:
    """Simulate a dataset: model photos of each garment and stereo scenes with their truth.

    Parameters
    ----------
    out : path
        Dataset directory to create.
    garments : sequence of str, optional
        Catalogue names (default: all 12, ``"No.1"`` ... ``"No.12"``).
    conditions : sequence of str
        Condition specs (:func:`parse_conditions`, e.g. ``"paper"``, ``"wood+wrinkles"``). For
        each condition with a target, ``scenes`` scenes of each garment; for one without
        (``"no-target"``), ``scenes`` scenes in all.
    scenes : int
        Scenes per garment and condition.
    seed : int
        Seed of the whole dataset.
    extra_garments : mapping of str to Garment, optional
        Users' own garments (:func:`load_garment`), simulated like catalogue ones.
    overwrite : bool
        Replace ``out`` if it exists and is not empty (otherwise that is an error).
    progress : callable(done, total, label), optional
        Called after every image written.

    Returns
    -------
    DatasetSummary

    Raises
    ------
    InputError
        ``out`` exists and is not empty (without ``overwrite``), or cannot be written.
    ValueError
        An unknown garment or condition, conditions asking for different lenses, or
        ``scenes < 1``.
    """
    out = Path(out)
    if scenes < 1:
        raise ValueError(f"scenes: expected at least 1, got {scenes}")
    names = list(garment_names() if garments is None else garments)
    chosen: dict[str, Garment] = {name: catalogue_garment(name) for name in names}
    for name, garment in (extra_garments or {}).items():
        if name in chosen:
            raise ValueError(f"garment name {name!r} is used twice")
        chosen[name] = garment
    for name in chosen:
        _check_name(name)
    specs = list(dict.fromkeys(conditions))
    if not specs:
        raise ValueError("conditions: expected at least one")
    parsed = {spec: parse_conditions(spec) for spec in specs}
    lenses = {c.lens for c in parsed.values()}
    if len(lenses) > 1:
        raise ValueError("conditions ask for different lenses "
                         f"({', '.join(sorted(lenses))}); a dataset has one stereo calibration: "
                         "simulate them into separate datasets")
    if any(c.target for c in parsed.values()) and not chosen:
        raise ValueError("garments: expected at least one")
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not overwrite:
        raise InputError(out, "already exists and is not empty (use --force to replace it)")
    jobs = _jobs(parsed, list(chosen), scenes)
    total = len(chosen) + len(jobs)
    tmp = out.parent / f".{out.name}.partial-{os.getpid()}"
    created = next((p for p in reversed(out.parents) if not p.exists()), None)
    complete = False
    try:
        if tmp.exists():
            shutil.rmtree(tmp)
        tmp.mkdir(parents=True)
        rig = hand_stereo_rig(lens=lenses.pop())
        camera = model_station_camera()
        save_stereo(tmp / "stereo.yaml", rig)
        save_camera(tmp / "model_camera.yaml", camera, distance_mm=MODEL_DISTANCE_MM)
        done = 0
        for name, garment in chosen.items():
            photo, background = render_model_photos(garment, camera,
                                                    scene_rng(seed, "model", name))
            write_image(tmp / "models" / name / "photo.bmp", photo)
            write_image(tmp / "models" / name / "background.bmp", background)
            done += 1
            if progress is not None:
                progress(done, total, f"model {name}")
        truth: dict[str, dict[str, Any]] = {}
        for scene_id, spec, name, k in jobs:
            cond = parsed[spec]
            target = chosen[name] if name is not None else None
            shot = simulate_scene(target, rig, cond, scene_rng(seed, spec, name or "", k))
            write_image(tmp / "scenes" / scene_id / "right.png", shot.right_bgr)
            write_image(tmp / "scenes" / scene_id / "left.png", shot.left_bgr)
            truth[scene_id] = {
                "model": name,
                "T_cam1_model": None if shot.T_cam1_model is None else shot.T_cam1_model.tolist(),
                "condition": spec,
                **shot.info,
            }
            done += 1
            if progress is not None:
                progress(done, total, f"scene {scene_id}")
        (tmp / "truth.json").write_text(dumps_json(truth))
        (tmp / "dataset.json").write_text(dumps_json(_manifest(seed, chosen, parsed, scenes)))
        if out.exists():
            shutil.rmtree(out) if out.is_dir() else out.unlink()
        os.replace(tmp, out)
        complete = True
    except OSError as exc:
        raise InputError(out, f"cannot write the dataset: {exc.strerror or exc}") from exc
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
        if not complete and created is not None and created.exists():
            shutil.rmtree(created, ignore_errors=True)  # folders this call made for ``out``
    return DatasetSummary(out, tuple(chosen), tuple(truth))


_NUMBER_LIST = re.compile(r"\[\s+([^\[\]{}\"]*?)\s+\]")


def dumps_json(data: Any) -> str:
    """JSON with one key per line but lists of numbers (matrix rows) on one line each."""
    text = json.dumps(data, indent=1)
    return _NUMBER_LIST.sub(lambda m: "[" + re.sub(r",\s+", ", ", m.group(1)) + "]", text) + "\n"


def _jobs(parsed: Mapping[str, Conditions], garments: list[str], scenes: int
          ) -> list[tuple[str, str, str | None, int]]:
    """(scene id, condition spec, garment or None, index) of every scene, in order."""
    jobs: list[tuple[str, str, str | None, int]] = []
    for spec, cond in parsed.items():
        if cond.target:
            jobs += [(f"{spec}_{name}_{k:04d}", spec, name, k)
                     for name in garments for k in range(scenes)]
        else:
            jobs += [(f"{spec}_{k:04d}", spec, None, k) for k in range(scenes)]
    return jobs


def _manifest(seed: int, garments: Mapping[str, Garment], parsed: Mapping[str, Conditions],
              scenes: int) -> dict[str, Any]:
    from importlib.metadata import version

    return {
        "format": "photomodel-dataset",
        "format_version": DATASET_FORMAT_VERSION,
        "generator": f"photomodel {version('photomodel')} (simulated)",
        "seed": int(seed),
        "scenes_per_garment": int(scenes),
        "garments": {name: {"size_mm": list(g.size_mm), "shape": g.shape,
                            "fabric": g.fabric,
                            "description": g.description}
                     for name, g in garments.items()},
        "conditions": {spec: dataclasses.asdict(c) for spec, c in parsed.items()},
    }
