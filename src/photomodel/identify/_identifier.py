"""``Identifier``: a model library prepared for one rig, then called once per stereo pair."""

from __future__ import annotations

import os
import time
import warnings
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from photomodel.camera import StereoRig
from photomodel.fitness import PreparedModel, StereoFeatures
from photomodel.identify._identify import IdentifyConfig, IdentifyResult, identify_in_features
from photomodel.library import ModelLibrary
from photomodel.locate import Locator, load_threshold
from photomodel.model import PhotoModel
from photomodel.search import SearchSpace

__all__ = ["Identifier"]


class Identifier:
    """Which model of a library lies on the table, and its pose, or none.

    Made once per library and rig: it loads the library's models (files that do not load are
    skipped with one warning each), prepares each for the rig, and reads the threshold; each
    call then pays for the screening and the searches only.

    Parameters
    ----------
    library : ModelLibrary or sequence of PhotoModel or Locator
        A :class:`~photomodel.Locator` given is used as it is (it must be for ``rig``): a
        service that adds one model makes a new Identifier without preparing the others.
    rig : StereoRig
    space : SearchSpace, optional
        The pose search box of every model (default as :class:`~photomodel.Locator`).
    config : IdentifyConfig, optional
        Candidates, retries, screening; its ``min_score`` overrides the threshold file.
    threshold : path, optional
        Threshold file (default: the library folder's ``threshold.json`` when it has one,
        else :func:`~photomodel.locate.threshold_path`'s).
    """

    def __init__(self, library: ModelLibrary | Sequence[PhotoModel | Locator], rig: StereoRig,
                 space: SearchSpace | None = None, *, config: IdentifyConfig | None = None,
                 threshold: str | os.PathLike[str] | None = None) -> None:
        root = None
        if isinstance(library, ModelLibrary):
            root = library.root
            models, skipped = library.load()
            for s in skipped:
                warnings.warn(str(s), stacklevel=2)
        else:
            models = list(library)
        config = config or IdentifyConfig()
        if config.min_score is None:
            config = replace(config, min_score=load_threshold(threshold,
                                                              library=root).min_score)
        self.config = config
        self.rig = rig
        for m in models:
            if isinstance(m, Locator) and m.rig is not rig:
                raise ValueError(f"library: the Locator of {m.model.name!r} is for another rig")
        self.locators = [m if isinstance(m, Locator)
                         else Locator(m, rig, space, min_score=config.min_score)
                         for m in models]
        self.space = self.locators[0].space if self.locators else (
            space or SearchSpace.from_ranges(R_cam1_plane=rig.R_cam1_facing))

    @property
    def models(self) -> list[PhotoModel]:
        """The library's models, in library order."""
        return [loc.model for loc in self.locators]

    @property
    def min_score(self) -> float:
        """The threshold applied."""
        assert self.config.min_score is not None
        return self.config.min_score

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
        prepared: list[PreparedModel] = [loc.prepared for loc in self.locators]
        return identify_in_features(prepared, features, config=self.config, space=self.space,
                                    rng=rng, t0=t0)

    def __len__(self) -> int:
        return len(self.locators)

    def __repr__(self) -> str:
        return f"Identifier({len(self)} models, min_score={self.min_score:.3f})"
