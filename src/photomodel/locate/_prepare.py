"""A model's preparation for a rig: what ``locate`` needs of it beside the images, built once."""

from __future__ import annotations

from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

from photomodel.fitness import (
    PreparedModel,
    SampleDrawer,
    ScanConfig,
    SoftFitness,
    StereoFeatures,
    as_prepared,
    level_spacing,
    prepare_scan,
    scan_spacing,
)
from photomodel.model import PhotoModel
from photomodel.search import PyramidConfig, SearchSpace

__all__ = ["prepare_model"]

def prepare_model(model: PhotoModel | PreparedModel, features: StereoFeatures, *,
                  space: SearchSpace | None = None, pyramid: PyramidConfig | None = None,
                  scans: Sequence[ScanConfig | None] = (ScanConfig(),)) -> bool:
    """Build and keep what locating ``model`` with this rig and search box needs beside the
    images, unless that was done before.

    That is the model's samples at every pyramid level the search refines, with every camera
    blur it may choose there (``pyramid.optics_blur_candidates_mm`` on the levels below the
    coarse level's next one, the global stage's blur above), drawn by one
    :class:`~photomodel.fitness.SampleDrawer`, and the kernels of every scan in ``scans``
    (:func:`~photomodel.fitness.prepare_scan`, on a second thread once their samples are
    drawn), so that no stereo pair pays for them. :class:`~photomodel.Locator` calls this
    once when it is made.

    Parameters
    ----------
    model : PhotoModel or PreparedModel
        What is built is kept in the PreparedModel (a bare PhotoModel keeps nothing).
    features : StereoFeatures
        Any stereo pair of the rig (its images are not read): the rig and image size
        (:meth:`~photomodel.fitness.StereoFeatures.blank` gives one without images).
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
    for level in range(top + 1):
        blurs = {config.optics_blur_mm}
        if level <= config.coarse_level - 2:
            blurs.update(config.optics_blur_candidates_mm)
        items.extend(("samples", level, blur) for blur in sorted(blurs))
    items.extend(("scan", scan, space.lower.tobytes(), space.upper.tobytes()) for scan in scans
                 if scan is not None and scan.level < features.levels)
    model = as_prepared(model)
    done: set[tuple[object, ...]] = model.kept.get("prepared", set)
    todo = [item for item in items if (base, item) not in done]
    if not todo:
        return False
    drawer = SampleDrawer(model)       # shares the photo's blurs and outline between them
    # Each scan's kernels on a second thread as soon as its samples are drawn, while the
    # other samples are drawn (both spend their time in OpenCV and numba, which release the
    # GIL); the scan whose samples are blurred least (drawn soonest) first.
    scans_todo = sorted((item[1] for item in todo if isinstance(item[1], ScanConfig)),
                        key=lambda scan: scan_spacing(scan).blur_mm)
    with ThreadPoolExecutor(max_workers=1) as pool:
        kernels = []
        for scan in scans_todo:
            drawer.draw([scan_spacing(scan)])
            kernels.append(pool.submit(prepare_scan, model, features, space.lower,
                                       space.upper, scan))
        drawer.draw(level_spacing(int(item[1]), optics_blur_mm=float(item[2]))
                    for item in todo if item[0] == "samples")
        for built in kernels:
            built.result()
    for item in todo:
        if item[0] == "samples":
            SoftFitness(model, features, int(item[1]), optics_blur_mm=float(item[2]))
        done.add((base, item))
    return True

