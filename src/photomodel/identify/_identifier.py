"""``Identifier``: a model library screened and verified for one rig, called once per pair,
with the garment's label read beside it."""

from __future__ import annotations

import os
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.errors import InputError, InputWarning
from photomodel.fitness import PreparedModel, StereoFeatures
from photomodel.identify._bank import DescriptorBank
from photomodel.identify._cache import CacheStats, PreparedModels
from photomodel.identify._identify import (
    IdentifyConfig,
    IdentifyResult,
    _model_rng,
    identify_with_bank,
    model_descriptor,
)
from photomodel.identify._labels import LabelRead, check_label, read_labels
from photomodel.identify._table import TableConfig, TableResult, identify_all
from photomodel.image import EXTRA_HINT, zxing_available
from photomodel.library import LibraryEntry, ModelLibrary
from photomodel.locate import LocateResult, Locator, load_threshold
from photomodel.model import PhotoModel
from photomodel.search import SearchSpace

__all__ = ["DEFAULT_PREPARED_MODELS", "Identifier"]

DEFAULT_PREPARED_MODELS = 32
"""Models an :class:`Identifier` of a library keeps prepared (about 20 MB each with 640 x 480
cameras)."""

_LABEL_ATTEMPT = 1000
"""The attempt number (in the seed of a model's search) of a search made for a label."""


def _stamp(path: Path) -> tuple[int, int, int] | None:
    """What tells a changed file: modification time, size and inode; None when missing."""
    try:
        st = path.stat()
    except OSError:
        return None
    return (st.st_mtime_ns, st.st_size, st.st_ino)


class Identifier:
    """Which model of a library lies on the table, and its pose, or none.

    Made once per library and rig: it reads the library's index (every model's descriptor;
    no model file is opened, an index without descriptors is upgraded first) and the
    threshold. Each call screens the whole library against the stereo pair and verifies the
    best-screened models by a pose search; a model is loaded and prepared for the rig the
    first time it is verified, and at most ``prepared_models`` are kept prepared (least
    recently used dropped).

    When the label map holds labels, each call also reads the labels in view (barcodes, QR
    codes, DataMatrix; :func:`~photomodel.identify.read_labels`, zxing-cpp, about 50-70 ms a
    pair) and names the garment through the map; the answer's ``label`` says whether that
    model is the photo-model's answer.
    When it is another one that was not verified, that model is located too, so that the
    answer can say whether it is in view (``label.found``); the photo-model's answer is
    never changed (docs/method/labels.md). Without zxing-cpp no label is read (one warning
    when the label map is not empty). :meth:`all` reads no labels.

    Parameters
    ----------
    library : ModelLibrary or sequence of PhotoModel or Locator
        A directory library (opened from its index), or models in memory. A
        :class:`~photomodel.Locator` given is used as it is (it must be for ``rig``).
    rig : StereoRig
    space : SearchSpace, optional
        The pose search box of every model (default as :class:`~photomodel.Locator`).
    config : IdentifyConfig, optional
        Candidates, retries, screening; its ``min_score`` overrides the threshold file.
    threshold : path, optional
        Threshold file (default: the library folder's ``threshold.json`` when it has one,
        else :func:`~photomodel.locate.threshold_path`'s).
    prepared_models : int, optional
        Most models kept prepared (default: :data:`DEFAULT_PREPARED_MODELS` for a directory
        library, every model for models in memory).
    prepare : callable(Locator) -> None, optional
        Extra work on each newly prepared Locator.
    label_map : mapping of str to str, optional
        Label text -> model name (default: for a directory library its ``labels.json``
        (:meth:`~photomodel.ModelLibrary.labels`), read again whenever the file changes; none
        for models in memory). An unreadable ``labels.json`` is one warning, and counts as
        an empty map until it is fixed.
    read_labels : bool or None
        Read the labels in each pair: always (True; an unmapped label is reported too),
        never (False), or while the label map holds any (None, the default: a library
        without labels pays nothing). Never without zxing-cpp.
    """

    def __init__(self, library: ModelLibrary | Sequence[PhotoModel | Locator], rig: StereoRig,
                 space: SearchSpace | None = None, *, config: IdentifyConfig | None = None,
                 threshold: str | os.PathLike[str] | None = None,
                 prepared_models: int | None = None,
                 prepare: Callable[[Locator], None] | None = None,
                 label_map: Mapping[str, str] | None = None,
                 read_labels: bool | None = None) -> None:
        config = config or IdentifyConfig()
        root = library.root if isinstance(library, ModelLibrary) else None
        if config.min_score is None:
            config = replace(config, min_score=load_threshold(threshold,
                                                              library=root).min_score)
        self.config = config
        self.rig = rig
        self.space = space or SearchSpace.from_ranges(R_cam1_plane=rig.R_cam1_facing)
        given: list[Locator] = []
        entries: dict[str, LibraryEntry] = {}
        if isinstance(library, ModelLibrary):
            self.library: ModelLibrary | None = library
            entries = self._read(library)
            names = list(entries)
            descriptors = [e.descriptor for e in entries.values()]
            load: Callable[[str], PhotoModel] = self._load_entry
            capacity = prepared_models or DEFAULT_PREPARED_MODELS
        else:
            self.library = None
            models: dict[str, PhotoModel] = {}
            for m in library:
                if isinstance(m, Locator):
                    if m.rig is not rig:
                        raise ValueError(f"library: the Locator of {m.model.name!r} is for "
                                         "another rig")
                    given.append(m)
                    models.setdefault(m.model.name, m.model)
                else:
                    models.setdefault(m.name, m)
            names = list(models)
            described = {loc.model.name: model_descriptor(loc.prepared) for loc in given}
            descriptors = [described.get(n) or model_descriptor(PreparedModel(models[n]))
                           for n in names]
            load = models.__getitem__
            capacity = prepared_models or max(1, len(names))
        if given:
            self.space = given[0].space
        assert all(d is not None for d in descriptors)   # described() described them all
        self._load = load
        # the library's state, swapped as one by reload() while calls may run
        self._state = (entries, DescriptorBank(names, descriptors))  # type: ignore[arg-type]
        self.prepared = PreparedModels(load, rig, capacity, space=self.space,
                                       min_score=config.min_score, prepare=prepare)
        for loc in given:
            self.prepared.put(loc)
        self._given_labels = None if label_map is None else dict(label_map)
        self._labels_stamp: tuple[int, int, int] | None = None
        self._labels: dict[str, str] = self._read_labels()
        self._read_mode = read_labels
        self._zxing = read_labels is not False and zxing_available()
        if read_labels is not False and not self._zxing and self._labels:
            where = self.library.labels_path if self.library is not None else "label_map"
            warnings.warn(InputWarning(where, f"{len(self._labels)} label(s) in the map, but "
                                              f"labels are not read without zxing-cpp: "
                                              f"{EXTRA_HINT}"), stacklevel=2)

    def _read_labels(self) -> dict[str, str]:
        """The label map: the one given, else the library's (one warning when it cannot be
        read), else none."""
        if self._given_labels is not None:
            return dict(self._given_labels)
        if self.library is None:
            return {}
        self._labels_stamp = _stamp(self.library.labels_path)
        try:
            return self.library.labels()
        except InputError as exc:
            warnings.warn(InputWarning(exc.source, f"{exc.problem}; no label names a model "
                                                   "until then"), stacklevel=3)
            return {}

    @property
    def reads_labels(self) -> bool:
        """Whether a call reads the labels in view now (see ``read_labels``)."""
        if not self._zxing or self._read_mode is False:
            return False
        return self._read_mode is True or bool(self._current_labels())

    @property
    def label_map(self) -> dict[str, str]:
        """Label text -> model name, as this Identifier reads labels (a copy)."""
        return dict(self._current_labels())

    def _current_labels(self) -> dict[str, str]:
        """The label map, the library's read again when its file changed (a ``models label``
        while a service runs)."""
        if (self._given_labels is None and self.library is not None
                and _stamp(self.library.labels_path) != self._labels_stamp):
            self._labels = self._read_labels()
        return self._labels

    @staticmethod
    def _read(library: ModelLibrary) -> dict[str, LibraryEntry]:
        """The library's described entries by name; one warning per skipped file."""
        scan = library.described()
        for s in scan.skipped:
            warnings.warn(str(s), stacklevel=3)
        return {e.name: e for e in scan.entries}

    @property
    def entries(self) -> dict[str, LibraryEntry]:
        """The library's index entries by name (empty for models in memory)."""
        return self._state[0]

    @property
    def bank(self) -> DescriptorBank:
        """Every model's descriptor, as the screen reads them."""
        return self._state[1]

    def _load_entry(self, name: str) -> PhotoModel:
        """Model ``name`` from the library's current state (the cache's loader)."""
        return self._loader(self.entries)(name)

    def _loader(self, entries: dict[str, LibraryEntry]) -> Callable[[str], PhotoModel]:
        """A loader of models from the library state ``entries`` (models in memory: those)."""
        library = self.library
        if library is None:
            return self._load
        return lambda name: library.load_entry(entries[name])

    def reload(self) -> None:
        """Read the library's index again (after a model was added, replaced or removed):
        the screen sees the library as it is now; prepared models whose file changed or
        went are dropped, the others kept."""
        if self.library is None:
            raise ValueError("reload: this Identifier holds models in memory, not a library")
        entries = self._read(self.library)
        for name, old in self.entries.items():
            new = entries.get(name)
            if new is None or (new.file, new.file_bytes, new.file_mtime_ns) != (
                    old.file, old.file_bytes, old.file_mtime_ns):
                self.prepared.drop(name)
        bank = DescriptorBank(list(entries), [e.descriptor for e in entries.values()
                                              if e.descriptor is not None])
        self._state = (entries, bank)

    @property
    def names(self) -> tuple[str, ...]:
        """The library's model names, in library order."""
        return self.bank.names

    @property
    def min_score(self) -> float:
        """The threshold applied."""
        assert self.config.min_score is not None
        return self.config.min_score

    def locator(self, name: str) -> Locator:
        """The prepared :class:`~photomodel.Locator` of model ``name`` (prepared now when it
        is not held)."""
        if name not in self.entries and name not in self.bank.index:
            raise KeyError(name)
        return self.prepared.get(name)

    def stats(self) -> CacheStats:
        """How many models are prepared, of how many at most, and the cache's counts."""
        return self.prepared.stats()

    def __call__(self, right_bgr: NDArray[np.uint8], left_bgr: NDArray[np.uint8],
                 rng: int | np.random.Generator | None = None) -> IdentifyResult:
        """Identify the model in one stereo pair (camera 1 and camera 2 images, BGR), and
        read its label."""
        t0 = time.perf_counter()
        features = StereoFeatures(self.rig, right_bgr, left_bgr)
        return self.identify_features(features, rng, t0=t0,
                                      labels=self.labels_in(right_bgr, left_bgr))

    def labels_in(self, right_bgr: NDArray[np.uint8], left_bgr: NDArray[np.uint8]
                  ) -> tuple[LabelRead, ...]:
        """The labels read in a pair (:func:`~photomodel.identify.read_labels`); none when
        this Identifier does not read labels now (:attr:`reads_labels`)."""
        return read_labels(right_bgr, left_bgr) if self.reads_labels else ()

    def identify_features(self, features: StereoFeatures,
                          rng: int | np.random.Generator | None = None, *,
                          t0: float | None = None,
                          labels: Sequence[LabelRead] | None = None) -> IdentifyResult:
        """:meth:`__call__` on a stereo pair already turned into features; ``labels``: the
        labels read in it (:meth:`labels_in`; None: the answer's ``label`` is None)."""
        t0 = time.perf_counter() if t0 is None else t0
        entries, bank = self._state   # one library state for the whole call
        load = self._loader(entries)

        def prepared(i: int) -> PreparedModel:
            return self.prepared.get(bank.names[i], load).prepared

        result = identify_with_bank(bank, prepared, features, config=self.config,
                                    space=self.space, rng=rng, t0=t0)
        if labels is None:
            return result
        base = int(np.random.default_rng(rng).integers(0, 2**62))

        def verify(name: str) -> tuple[LocateResult | None, bool | None]:
            """Model ``name`` located in this pair, and whether it counts as found."""
            if result.model == name and result.best is not None:
                return result.best, True
            hit = next((c.result for c in result.candidates
                        if c.model == name and c.result is not None), None)
            if hit is None:
                if name not in bank.index:
                    return None, None
                hit = self.prepared.get(name, load).locate_features(
                    features, _model_rng(base, name, _LABEL_ATTEMPT), t0=time.perf_counter())
            # identify_with_bank's test of a candidate
            return hit, bool(hit.score >= self.min_score
                             and not hit.visible_outline < self.config.min_visible_outline)

        check = check_label(labels, self._current_labels(), result.model, verify)
        return replace(result, label=check, seconds=time.perf_counter() - t0)

    def all(self, right_bgr: NDArray[np.uint8], left_bgr: NDArray[np.uint8],
            rng: int | np.random.Generator | None = None, *,
            table: TableConfig | None = None) -> TableResult:
        """Every library garment in one stereo pair, which lies on which, and the pick order
        (:func:`~photomodel.identify.identify_all`)."""
        t0 = time.perf_counter()
        return self.all_in_features(StereoFeatures(self.rig, right_bgr, left_bgr), rng,
                                    table=table, t0=t0)

    def all_in_features(self, features: StereoFeatures,
                        rng: int | np.random.Generator | None = None, *,
                        table: TableConfig | None = None, t0: float | None = None
                        ) -> TableResult:
        """:meth:`all` on a stereo pair already turned into features."""
        entries, bank = self._state
        load = self._loader(entries)

        def prepared(i: int) -> PreparedModel:
            return self.prepared.get(bank.names[i], load).prepared

        return identify_all(bank, prepared, features, config=self.config, table=table,
                            space=self.space, rng=rng, t0=t0)

    def __len__(self) -> int:
        return len(self.bank)

    def __repr__(self) -> str:
        return (f"Identifier({len(self)} models, {len(self.prepared)} prepared, "
                f"min_score={self.min_score:.3f})")
