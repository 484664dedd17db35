"""``Identifier``: a model library screened and verified for one rig, called once per pair."""

from __future__ import annotations

import os
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.fitness import PreparedModel, StereoFeatures
from photomodel.identify._bank import DescriptorBank
from photomodel.identify._cache import CacheStats, PreparedModels
from photomodel.identify._identify import (
    IdentifyConfig,
    IdentifyResult,
    identify_with_bank,
    model_descriptor,
)
from photomodel.identify._table import TableConfig, TableResult, identify_all
from photomodel.library import LibraryEntry, ModelLibrary
from photomodel.locate import Locator, load_threshold
from photomodel.model import PhotoModel
from photomodel.search import SearchSpace

__all__ = ["DEFAULT_PREPARED_MODELS", "Identifier"]

DEFAULT_PREPARED_MODELS = 32
"""Models an :class:`Identifier` of a library keeps prepared (about 20 MB each with 640 x 480
cameras)."""


class Identifier:
    """Which model of a library lies on the table, and its pose, or none.

    Made once per library and rig: it reads the library's index (every model's descriptor;
    no model file is opened, an index without descriptors is upgraded first) and the
    threshold. Each call screens the whole library against the stereo pair and verifies the
    best-screened models by a pose search; a model is loaded and prepared for the rig the
    first time it is verified, and at most ``prepared_models`` are kept prepared (least
    recently used dropped).

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
    """

    def __init__(self, library: ModelLibrary | Sequence[PhotoModel | Locator], rig: StereoRig,
                 space: SearchSpace | None = None, *, config: IdentifyConfig | None = None,
                 threshold: str | os.PathLike[str] | None = None,
                 prepared_models: int | None = None,
                 prepare: Callable[[Locator], None] | None = None) -> None:
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
        """Identify the model in one stereo pair (camera 1 and camera 2 images, BGR)."""
        t0 = time.perf_counter()
        features = StereoFeatures(self.rig, right_bgr, left_bgr)
        return self.identify_features(features, rng, t0=t0)

    def identify_features(self, features: StereoFeatures,
                          rng: int | np.random.Generator | None = None, *,
                          t0: float | None = None) -> IdentifyResult:
        """:meth:`__call__` on a stereo pair already turned into features."""
        entries, bank = self._state   # one library state for the whole call
        load = self._loader(entries)

        def prepared(i: int) -> PreparedModel:
            return self.prepared.get(bank.names[i], load).prepared

        return identify_with_bank(bank, prepared, features, config=self.config,
                                  space=self.space, rng=rng, t0=t0)

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
