"""A simulated dataset directory, as ``photomodel simulate`` writes it (docs/contracts.md).

::

    DIR/stereo.yaml                    stereo calibration (camera 1 = reference)
    DIR/model_camera.yaml              model-station camera (with distance_mm)
    DIR/models/<name>/photo.bmp        the garment on the green plane
    DIR/models/<name>/background.bmp   the plane alone
    DIR/scenes/<id>/right.png          camera 1
    DIR/scenes/<id>/left.png           camera 2 (with ``table``: ids ``table<N>_<index>``)
    DIR/truth.json                     {"<id>": {"model": ..., "T_cam1_model": ..., ...}}
                                       (with ``labels``: the target's ``label`` too)
    DIR/dataset.json                   how it was made: seed, garments, conditions, versions
    DIR/calibration/                   chessboard views with their truth (only with
                                       ``calibration_views``; photomodel.sim._calibration)

Every image has its own seed, derived from the dataset's seed and the names (condition,
garment, index) of what it shows, so the same seed gives byte-identical files, and adding a
garment or a condition leaves the other scenes unchanged. A large ``library`` (model photos of
catalogue articles without scenes: ``simulate --catalogue N``) is rendered by worker
processes; each photo's bytes depend only on its seed, never on the workers. The directory is
built beside its final place and moved there only when complete; the scenes are written one by
one (memory does not grow with their number). ``overwrite`` replaces only a dataset (a
directory with ``dataset.json``), never a file or another directory.
"""

from __future__ import annotations

import dataclasses
import json
import multiprocessing
import os
import re
import sys
import zlib
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import PinholeCamera, StereoRig, save_camera, save_stereo
from photomodel.image import write_image
from photomodel.sim._catalogue import _spec as _garment_spec
from photomodel.sim._catalogue import catalogue_garment, garment_names
from photomodel.sim._conditions import Conditions, parse_conditions
from photomodel.sim._folders import build_folder, check_out, is_ours
from photomodel.sim._garments import Garment
from photomodel.sim._rigs import MODEL_DISTANCE_MM, hand_stereo_rig, model_station_camera
from photomodel.sim._scenes import render_model_photos, simulate_scene

__all__ = [
    "DATASET_FORMAT_VERSION",
    "MAX_SCENES",
    "DatasetSummary",
    "check_garment_name",
    "dumps_json",
    "is_dataset",
    "scene_rng",
    "write_dataset",
]

DATASET_FORMAT_VERSION = 1
_FORMAT = "photomodel-dataset"
MAX_SCENES = 10_000
"""Most scenes per garment and condition (the paper's study is 1000)."""
MAX_SEED = 2**32 - 1
LIBRARY_WORKERS = 2
"""Worker processes that render a large ``library``'s model photos."""
_PARALLEL_FROM = 16  # fewer library photos than this are rendered in this process


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


def check_garment_name(name: str) -> None:
    """ValueError (``garments: ...``) when ``name`` cannot be a garment's directory name."""
    if (not name or name in (".", "..") or name.startswith(".") or not name.isprintable()
            or name != name.strip() or len(name) > 100
            or any(c in name for c in '/\\:*?"<>|')):
        raise ValueError(f"garments: garment name {name!r} cannot be a directory name "
                         "(printable, at most 100 characters, no path separators or leading "
                         "dot)")


def is_dataset(path: Path) -> bool:
    """Whether ``path`` is a directory that :func:`write_dataset` wrote (its ``dataset.json``
    says so)."""
    return is_ours(path, "dataset.json", _FORMAT)


def write_dataset(
    out: str | os.PathLike[str],
    garments: Sequence[str] | None = None,
    conditions: Sequence[str] = ("paper",),
    scenes: int = 1,
    seed: int = 0,
    *,
    extra_garments: Mapping[str, Garment] | None = None,
    library: Sequence[str] = (),
    overwrite: bool = False,
    progress: Callable[[int, int, str], None] | None = None,
    calibration_views: int = 0,
    workers: int | None = None,
    table: int | None = None,
    labels: bool = False,
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
        Scenes per garment and condition, 1 to :data:`MAX_SCENES`.
    seed : int
        Seed of the whole dataset, 0 to 2**32 - 1.
    extra_garments : mapping of str to Garment, optional
        Users' own garments (:func:`load_garment`), simulated like catalogue ones.
    library : sequence of str
        Catalogue names (typically of the simulated catalogue, ``catalogue_names(n)``) whose
        model photos are written too, without scenes of their own: the models of an
        identification library. Names also in ``garments`` are written once. With a library,
        ``garments`` may be empty: then only the conditions without a target give scenes, and
        a dataset may have none (``truth.json`` is ``{}``). Each model photo takes about
        1.8 MB.
    overwrite : bool
        Replace ``out`` if it is a dataset (has ``dataset.json``); a non-empty ``out`` is
        otherwise an error, and a file or a directory of anything else always is.
    progress : callable(done, total, label), optional
        Called after every image written.
    calibration_views : int
        0 (default) for none, else also write ``calibration/``: chessboard views with their
        truth, this many per set (:func:`~photomodel.sim._calibration.write_calibration`).
    workers : int, optional
        Processes that render the library's model photos (default: :data:`LIBRARY_WORKERS`
        when it holds at least 16 garments not in ``garments``, else 1, in this process).
        The files do not depend on it.
    table : int, optional
        Instead of one scene per garment, ``scenes`` scenes per condition of a table with
        this many garments (2 to 6, :func:`~photomodel.sim.simulate_table`) drawn from
        ``garments`` (a model may appear twice): ``scenes/table<N>_<index>/`` (with several
        conditions, ``<condition>_table<N>_<index>``), their truth the pick-first garment's
        ``model`` and ``T_cam1_model`` plus ``table``, ``garments`` and ``distractors``
        (docs/contracts.md). A table's images depend on the whole list of garments.
    labels : bool
        Every garment (catalogue and ``extra_garments``; not the library's) carries a printed
        label (:func:`~photomodel.sim.random_label`: a QR code, DataMatrix or Code 128 of
        :func:`~photomodel.sim.article_code`, its size, place and format drawn from the
        seed and the garment's name), in its model photos and scenes; each scene's truth
        gains ``label`` (:meth:`~photomodel.sim.GarmentLabel.truth`; on a table, each
        garment's entry), ``dataset.json`` each garment's label. Needs zxing-cpp.

    Returns
    -------
    DatasetSummary

    Raises
    ------
    InputError
        ``out`` exists and is not empty (without ``overwrite``), is a file or a directory that
        is not a dataset, or cannot be written.
    ValueError
        An unknown garment or condition, conditions asking for different lenses, ``scenes``
        or ``seed`` out of range; the message starts with the argument (``scenes: ...``).
    """
    out = Path(out)
    _check_counts(scenes, seed, workers, calibration_views)
    chosen = _chosen_garments(garments, extra_garments, labels, seed)
    shelf = _library_names(library, chosen)
    parsed, lens = _parsed_conditions(conditions)
    if any(c.target for c in parsed.values()) and not chosen and not shelf:
        raise ValueError("garments: expected at least one")
    if table is not None:
        _check_table(table, parsed, chosen)
    check_out(out, overwrite, "dataset.json", _FORMAT, "a dataset")
    writer = _Writer(_Plan(seed, scenes, chosen, shelf, parsed, lens, table, calibration_views,
                           workers), progress)
    build_folder(out, "dataset.json", _FORMAT, writer, "the dataset")
    return DatasetSummary(out, (*chosen, *shelf), tuple(writer.scene_ids))


def _check_counts(scenes: int, seed: int, workers: int | None, calibration_views: int) -> None:
    """ValueError (``calibration_views: ...``, ``scenes: ...``, ``seed: ...``,
    ``workers: ...``, in this order) for a count of :func:`write_dataset` out of range."""
    from photomodel.sim._calibration import MAX_CALIBRATION_VIEWS, MIN_CALIBRATION_VIEWS

    if calibration_views != 0 and not (MIN_CALIBRATION_VIEWS <= calibration_views
                                       <= MAX_CALIBRATION_VIEWS):
        raise ValueError(f"calibration_views: expected 0 (none) or an integer from "
                         f"{MIN_CALIBRATION_VIEWS} to {MAX_CALIBRATION_VIEWS}, got "
                         f"{calibration_views}")
    if not 1 <= scenes <= MAX_SCENES:
        raise ValueError(f"scenes: expected an integer from 1 to {MAX_SCENES}, got {scenes}")
    if not 0 <= seed <= MAX_SEED:
        raise ValueError(f"seed: expected an integer from 0 to {MAX_SEED}, got {seed}")
    if workers is not None and not 1 <= workers <= 64:
        raise ValueError(f"workers: expected an integer from 1 to 64, got {workers}")


def _chosen_garments(garments: Sequence[str] | None, extra_garments: Mapping[str, Garment] | None,
                     labels: bool, seed: int) -> dict[str, Garment]:
    """The garments with scenes by name: the catalogue's ``garments`` (default all 12), then
    ``extra_garments``, each with its printed label when ``labels``; ValueError
    (``garments: ...``) for a name used twice or that cannot be a directory name."""
    names = list(garment_names() if garments is None else garments)
    chosen: dict[str, Garment] = {name: catalogue_garment(name) for name in names}
    for name, garment in (extra_garments or {}).items():
        if name in chosen:
            raise ValueError(f"garments: garment name {name!r} is used twice")
        chosen[name] = garment
    for name in chosen:
        check_garment_name(name)
    if labels:
        from photomodel.sim._labels import random_label

        chosen = {name: random_label(g, name, seed, scene_rng(seed, "label", name))
                  for name, g in chosen.items()}
    return chosen


def _parsed_conditions(conditions: Sequence[str]) -> tuple[dict[str, Conditions], str]:
    """Each distinct condition spec, in order, parsed, and the one lens they share;
    ValueError (``conditions: ...``) for none or for different lenses."""
    specs = list(dict.fromkeys(conditions))
    if not specs:
        raise ValueError("conditions: expected at least one")
    parsed = {spec: parse_conditions(spec) for spec in specs}
    lenses = {c.lens for c in parsed.values()}
    if len(lenses) > 1:
        raise ValueError("conditions ask for different lenses "
                         f"({', '.join(sorted(lenses))}); a dataset has one stereo calibration: "
                         "simulate them into separate datasets")
    return parsed, lenses.pop()


@dataclass(frozen=True)
class _Plan:
    """What one :func:`write_dataset` call writes (its checked arguments): the garments with
    scenes (``chosen``), the library's other names (``shelf``), the parsed conditions by
    spec and their lens, and the counts."""

    seed: int
    scenes: int
    chosen: dict[str, Garment]
    shelf: list[str]
    parsed: dict[str, Conditions]
    lens: str
    table: int | None
    calibration_views: int
    workers: int | None

    def image_count(self) -> int:
        """Model photo pairs, scenes and calibration images: the progress's total."""
        from photomodel.sim._calibration import calibration_image_count

        scene_count = (_count_jobs(self.parsed, len(self.chosen), self.scenes)
                       if self.table is None else len(self.parsed) * self.scenes)
        return (len(self.chosen) + len(self.shelf) + scene_count
                + calibration_image_count(self.calibration_views))

    def jobs(self) -> Iterator[tuple[str, str, str | None, int]]:
        """(scene id, condition spec, garment or None, index) of every scene, in order."""
        return (_jobs(self.parsed, list(self.chosen), self.scenes) if self.table is None
                else _table_jobs(self.parsed, self.table, self.scenes))

    def scene(self, rig: StereoRig, spec: str, name: str | None, k: int
              ) -> tuple[NDArray[np.uint8], NDArray[np.uint8], dict[str, Any]]:
        """Camera 1's and camera 2's images (H, W, 3) of scene ``k`` of garment ``name`` (or
        of a table, or none) under condition ``spec``, and its truth entry (with the labels'
        truth where the garments carry one)."""
        cond = self.parsed[spec]
        if self.table is not None:
            right, left, facts = _table_scene(list(self.chosen.values()), self.table, rig, cond,
                                              scene_rng(self.seed, spec, f"table{self.table}", k),
                                              spec)
            for g in facts.get("garments", []):
                label = self.chosen[g["model"]].label if g["model"] in self.chosen else None
                if label is not None:
                    g["label"] = label.truth(rig, np.asarray(g["T_cam1_model"]))
            return right, left, facts
        target = self.chosen[name] if name is not None else None
        shot = simulate_scene(target, rig, cond, scene_rng(self.seed, spec, name or "", k))
        facts = {
            "model": name,
            "T_cam1_model": (None if shot.T_cam1_model is None
                             else shot.T_cam1_model.tolist()),
            "condition": spec,
            **shot.info,
        }
        if target is not None and target.label is not None and shot.T_cam1_model is not None:
            facts["label"] = target.label.truth(rig, shot.T_cam1_model)
        return shot.right_bgr, shot.left_bgr, facts

    def manifest(self) -> dict[str, Any]:
        """``dataset.json``: how the dataset was made."""
        manifest = _manifest(self.seed, self.chosen, self.parsed, self.scenes)
        if self.table is not None:
            manifest["table"] = int(self.table)
        if self.shelf:
            manifest["library"] = _library_manifest(self.shelf)
        if self.calibration_views:
            manifest["calibration"] = {"views": int(self.calibration_views),
                                       "readme": "calibration/README.txt"}
        return manifest


class _Writer:
    """Writes a :class:`_Plan` into the directory being built (:func:`build_folder`'s
    callback), calling ``progress(done, total, label)`` after every image; keeps the ids of
    the scenes written."""

    def __init__(self, plan: _Plan, progress: Callable[[int, int, str], None] | None) -> None:
        self.plan, self.progress = plan, progress
        self.total = plan.image_count()
        self.done = 0
        self.scene_ids: list[str] = []

    def __call__(self, tmp: Path) -> None:
        """``stereo.yaml``, ``model_camera.yaml``, the model photos, the scenes with
        ``truth.json``, the chessboard views and ``dataset.json``, into ``tmp``."""
        from photomodel.sim._calibration import write_calibration

        plan = self.plan
        rig = hand_stereo_rig(lens=plan.lens)
        camera = model_station_camera()
        save_stereo(tmp / "stereo.yaml", rig)
        save_camera(tmp / "model_camera.yaml", camera, distance_mm=MODEL_DISTANCE_MM)
        self._models(tmp, camera)
        self._scenes(tmp, rig)
        if plan.calibration_views:
            write_calibration(tmp, rig, camera, plan.calibration_views, plan.seed,
                              progress=self._tick)
        (tmp / "dataset.json").write_text(dumps_json(plan.manifest()))

    def _tick(self, label: str) -> None:
        """One more image written (``label`` says which)."""
        self.done += 1
        if self.progress is not None:
            self.progress(self.done, self.total, label)

    def _models(self, tmp: Path, camera: PinholeCamera) -> None:
        """``models/<name>/photo.bmp`` and ``background.bmp`` of the garments with scenes,
        then of the library's others."""
        plan = self.plan
        for name, garment in plan.chosen.items():
            photo, background = render_model_photos(garment, camera,
                                                    scene_rng(plan.seed, "model", name))
            write_image(tmp / "models" / name / "photo.bmp", photo)
            write_image(tmp / "models" / name / "background.bmp", background)
            self._tick(f"model {name}")
        for name in _write_library(tmp, plan.shelf, plan.seed, camera, plan.workers):
            self._tick(f"model {name}")

    def _scenes(self, tmp: Path, rig: StereoRig) -> None:
        """``scenes/<id>/right.png`` and ``left.png`` of every scene, and ``truth.json``, one
        scene's entry at a time."""
        with open(tmp / "truth.json", "w") as truth:
            truth.write("{")
            for scene_id, spec, name, k in self.plan.jobs():
                right, left, facts = self.plan.scene(rig, spec, name, k)
                write_image(tmp / "scenes" / scene_id / "right.png", right)
                write_image(tmp / "scenes" / scene_id / "left.png", left)
                # The text dumps_json gives this entry inside the whole dict.
                entry = dumps_json({scene_id: facts})[1:-3]
                truth.write(("," if self.scene_ids else "") + entry)
                self.scene_ids.append(scene_id)
                self._tick(f"scene {scene_id}")
            truth.write("\n}\n" if self.scene_ids else "}\n")


def _library_names(library: Sequence[str], chosen: Mapping[str, Garment]) -> list[str]:
    """The library's names not in ``chosen``, in order, without repeats; ValueError
    (``library: ...``) for a name that is no catalogue garment."""
    if isinstance(library, str):
        raise ValueError("library: expected a sequence of garment names, got a string")
    shelf = [name for name in dict.fromkeys(library) if name not in chosen]
    for name in shelf:
        if not isinstance(name, str) or _garment_spec(name) is None:
            raise ValueError(f"library: no catalogue garment {name!r} (expected names such as "
                             "No.3 or cat-00042)")
        check_garment_name(name)
    return shelf


def _write_library(tmp: Path, names: Sequence[str], seed: int, camera: PinholeCamera,
                   workers: int | None) -> Iterator[str]:
    """Write the model photos of catalogue garments ``names`` into ``tmp/models/``, yielding
    each name once its photos are written, in order; in worker processes when there are many
    (see :func:`write_dataset`), else, or when workers cannot start, in this process."""
    if workers is None:
        workers = min(LIBRARY_WORKERS, os.cpu_count() or 1) if len(names) >= _PARALLEL_FROM else 1
    jobs = [(str(tmp), name, seed, camera) for name in names]
    done = 0
    if workers > 1 and len(names) > 1 and _can_spawn():
        try:
            with ProcessPoolExecutor(max_workers=workers,
                                     mp_context=multiprocessing.get_context("spawn"),
                                     initializer=_init_worker, initargs=(os.getpid(),)) as pool:
                # In order, a few at a time per worker; leaving early cancels the rest.
                for name in pool.map(_write_model_photos, jobs, chunksize=4):
                    done += 1
                    yield name
        except BrokenProcessPool:
            pass  # a worker died (killed, out of memory): the rest in this process
    for job in jobs[done:]:
        yield _write_model_photos(job)


def _can_spawn() -> bool:
    """Whether spawned workers can start: they run the main script again by its path, which a
    program read from stdin (``python -``) does not have."""
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    return path is None or Path(path).is_file()


def _init_worker(parent_pid: int) -> None:
    """Initialiser of a library worker: ends with the process that started it, leaves Ctrl-C
    to it (which stops the pool and removes the half-built dataset), one numba thread (the
    processes give the parallelism)."""
    import signal

    import numba

    from photomodel._process import die_with_parent

    die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    numba.set_num_threads(1)


def _write_model_photos(job: tuple[str, str, int, PinholeCamera]) -> str:
    """Render and write ``models/<name>/photo.bmp`` and ``background.bmp`` of one catalogue
    garment (a worker's job: (dataset directory, name, seed, model camera)); its name."""
    tmp, name, seed, camera = job
    garment = catalogue_garment(name)
    photo, background = render_model_photos(garment, camera, scene_rng(seed, "model", name))
    write_image(Path(tmp) / "models" / name / "photo.bmp", photo)
    write_image(Path(tmp) / "models" / name / "background.bmp", background)
    return name


def _library_manifest(names: Sequence[str]) -> dict[str, Any]:
    """``dataset.json``'s ``library``: each garment's size, shape, fabric and description."""
    out: dict[str, Any] = {}
    for name in names:
        spec = _garment_spec(name)
        assert spec is not None
        out[name] = {"size_mm": list(spec.size_mm), "shape": spec.shape, "fabric": spec.fabric,
                     "description": spec.description}
    return out


_NUMBER_LIST = re.compile(r"\[\s+([^\[\]{}\"]*?)\s+\]")


def dumps_json(data: Any) -> str:
    """JSON with one key per line but lists of numbers (matrix rows) on one line each."""
    text = json.dumps(data, indent=1)
    return _NUMBER_LIST.sub(lambda m: "[" + re.sub(r",\s+", ", ", m.group(1)) + "]", text) + "\n"


def _jobs(parsed: Mapping[str, Conditions], garments: list[str], scenes: int
          ) -> Iterator[tuple[str, str, str | None, int]]:
    """(scene id, condition spec, garment or None, index) of every scene, in order."""
    for spec, cond in parsed.items():
        if cond.target:
            for name in garments:
                for k in range(scenes):
                    yield f"{spec}_{name}_{k:04d}", spec, name, k
        else:
            for k in range(scenes):
                yield f"{spec}_{k:04d}", spec, None, k


def _check_table(table: int, parsed: Mapping[str, Conditions],
                 chosen: Mapping[str, Garment]) -> None:
    """ValueError (``table: ...``, ``conditions: ...``, ``garments: ...``) unless a table of
    ``table`` garments can be simulated under every condition."""
    from photomodel.sim._table import MAX_TABLE_GARMENTS, MIN_TABLE_GARMENTS

    if isinstance(table, bool) or not isinstance(table, int) or not (
            MIN_TABLE_GARMENTS <= table <= MAX_TABLE_GARMENTS):
        raise ValueError(f"table: expected an integer from {MIN_TABLE_GARMENTS} to "
                         f"{MAX_TABLE_GARMENTS}, got {table}")
    empty = [spec for spec, cond in parsed.items() if not cond.target]
    if empty:
        raise ValueError(f"conditions: {', '.join(empty)} has no garments; a table needs "
                         "conditions with a target")
    if not chosen:
        raise ValueError("garments: a table needs at least one garment")


def _table_jobs(parsed: Mapping[str, Conditions], table: int, scenes: int
                ) -> Iterator[tuple[str, str, str | None, int]]:
    """(scene id, condition spec, None, index) of every table scene, in order."""
    for spec in parsed:
        prefix = f"table{table}" if len(parsed) == 1 else f"{spec}_table{table}"
        for k in range(scenes):
            yield f"{prefix}_{k:04d}", spec, None, k


def _table_scene(pool: list[Garment], table: int, rig: StereoRig, cond: Conditions,
                 rng: np.random.Generator, spec: str
                 ) -> tuple[NDArray[np.uint8], NDArray[np.uint8], dict[str, Any]]:
    """Camera 1's and camera 2's images of a random table and its truth entry."""
    from photomodel.sim._table import simulate_table

    shot, info = simulate_table(pool, table, rig, cond, rng)
    truth = shot.to_json_dict()
    facts = {"model": truth.pop("model"), "T_cam1_model": truth.pop("T_cam1_model"),
             "condition": spec, **info, **truth}
    return shot.right_bgr, shot.left_bgr, facts


def _count_jobs(parsed: Mapping[str, Conditions], garments: int, scenes: int) -> int:
    """How many scenes :func:`_jobs` gives."""
    return sum(scenes * (garments if cond.target else 1) for cond in parsed.values())


def _manifest(seed: int, garments: Mapping[str, Garment], parsed: Mapping[str, Conditions],
              scenes: int) -> dict[str, Any]:
    from importlib.metadata import version

    return {
        "format": _FORMAT,
        "format_version": DATASET_FORMAT_VERSION,
        "generator": f"photomodel {version('photomodel')} (simulated)",
        "seed": int(seed),
        "scenes_per_garment": int(scenes),
        "garments": {name: {"size_mm": list(g.size_mm), "shape": g.shape,
                            "fabric": g.fabric,
                            "description": g.description,
                            **({} if g.label is None else {"label": {
                                "text": g.label.text, "format": g.label.format,
                                "module_mm": g.label.module_mm,
                                "centre_mm": list(g.label.centre_mm),
                                "angle_deg": g.label.angle_deg}})}
                     for name, g in garments.items()},
        "conditions": {spec: dataclasses.asdict(c) for spec, c in parsed.items()},
    }
