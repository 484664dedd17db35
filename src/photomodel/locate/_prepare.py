"""A model's preparation for a rig: what ``locate`` needs of it beside the images, built once."""

from __future__ import annotations

from collections.abc import Sequence

from photomodel._owned import owned
from photomodel.fitness import ScanConfig, SoftFitness, StereoFeatures, prepare_scan
from photomodel.model import PhotoModel
from photomodel.search import PyramidConfig, SearchSpace

__all__ = ["prepare_model"]

_PREPARED: dict[int, set[tuple[object, ...]]] = {}
"""What was prepared, per model object (while it lives): (rig, image size and match; item)."""


def prepare_model(model: PhotoModel, features: StereoFeatures, *,
                  space: SearchSpace | None = None, pyramid: PyramidConfig | None = None,
                  scans: Sequence[ScanConfig | None] = (ScanConfig(),)) -> bool:
    """Build and keep what locating ``model`` with this rig and search box needs beside the
    images, unless that was done before.

    That is the model's samples at every pyramid level the search refines, with every camera
    blur it may choose there (``pyramid.optics_blur_candidates_mm`` on the levels below the
    coarse level's next one, the global stage's blur above), and the kernels of every scan in
    ``scans`` (:func:`~photomodel.fitness.prepare_scan`). Each is otherwise built at its
    first use, in whatever stereo pair first needs it: a scene under a blurred lens or a
    scan of level 3 (about one scene in eight) paid 10-40 ms more than the next such scene.
    :func:`~photomodel.locate.locate_in_features` calls this with the model's first stereo
    pair (per rig, box and settings); a cell that loads its models can call it before the
    first pair arrives.

    Parameters
    ----------
    model : PhotoModel
    features : StereoFeatures
        Any stereo pair of the rig (its images are not read): the rig and image size.
    space : SearchSpace, optional
        The search box (default: as :func:`~photomodel.locate.locate`).
    pyramid : PyramidConfig, optional
        The search's settings (default ``PyramidConfig()``).
    scans : sequence of ScanConfig or None
        The scans to prepare (None entries and levels the features lack are skipped).

    Returns
    -------
    bool
        True when anything was prepared, False when all of it was before.
    """
    space = space or SearchSpace.from_ranges(R_cam1_plane=features.rig.R_cam1_facing)
    config = pyramid or PyramidConfig()
    rig = features.rig
    base = (rig.calibration_key, features.pyramids[0][0].shape, features.match)
    items: list[tuple[object, ...]] = []
    top = min(config.coarse_level, features.levels - 1)
    for level in range(config.finest_level, top + 1):
        blurs = {config.optics_blur_mm}
        if level <= config.coarse_level - 2:
            blurs.update(config.optics_blur_candidates_mm)
        items.extend(("samples", level, blur) for blur in sorted(blurs))
    items.extend(("scan", scan, space.lower.tobytes(), space.upper.tobytes()) for scan in scans
                 if scan is not None and scan.level < features.levels)
    done = owned(_PREPARED, model, set)
    todo = [item for item in items if (base, item) not in done]
    for item in todo:
        if item[0] == "samples":
            SoftFitness(model, features, int(item[1]), optics_blur_mm=float(item[2]))
        else:
            scan = item[1]
            assert isinstance(scan, ScanConfig)
            prepare_scan(model, features, space.lower, space.upper, scan)
        done.add((base, item))
    return bool(todo)
