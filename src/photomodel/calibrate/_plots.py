"""Pictures of a calibration, written beside its file: where the corners fell in each image
(coverage) and each view's reprojection error.

Both are drawn with matplotlib's Agg backend into memory (:func:`coverage_png`,
:func:`errors_png`) so that a command writes them only once the calibration succeeded.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from photomodel._files import write_atomic
from photomodel.calibrate._calibrate import CameraCalibration, StereoCalibration

__all__ = ["coverage_png", "errors_png", "plot_paths", "write_plots"]


def plot_paths(out: str | os.PathLike[str]) -> tuple[Path, Path]:
    """``OUT.coverage.png`` and ``OUT.errors.png`` beside the calibration file ``OUT``
    (its suffix replaced: ``stereo.yaml`` -> ``stereo.coverage.png``)."""
    p = Path(out)
    stem = p.stem if p.suffix else p.name
    return p.with_name(f"{stem}.coverage.png"), p.with_name(f"{stem}.errors.png")


def _figure(ncols: int, width: float, height: float):  # type: ignore[no-untyped-def]
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width * ncols, height), dpi=100, layout="constrained")
    return fig, [fig.add_subplot(1, ncols, k + 1) for k in range(ncols)]


def _png(fig) -> bytes:  # type: ignore[no-untyped-def]
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return buf.getvalue()


def _coverage_axes(ax, title: str, calibration: CameraCalibration) -> None:  # type: ignore[no-untyped-def]
    import matplotlib as mpl

    w, h = calibration.camera.image_size
    cmap = mpl.colormaps["viridis"]
    n = len(calibration.corners)
    ax.add_patch(mpl.patches.Rectangle((-0.5, -0.5), w, h, fill=False, color="black", lw=1.0))
    for k, corners in enumerate(calibration.corners):
        colour = cmap(k / max(n - 1, 1))
        hull = _outline(corners)
        ax.plot(hull[:, 0], hull[:, 1], color=colour, lw=0.6, alpha=0.7)
        ax.scatter(corners[:, 0], corners[:, 1], s=2, color=colour)
    ax.set_xlim(-0.5 - 0.02 * w, w - 0.5 + 0.02 * w)
    ax.set_ylim(h - 0.5 + 0.02 * h, -0.5 - 0.02 * h)
    ax.set_aspect("equal")
    ax.set_title(f"{title}: corners of {n} views ({w}x{h} px)", fontsize=9)
    ax.set_xlabel("u (px)")
    ax.set_ylabel("v (px)")


def _outline(corners: NDArray[np.float64]) -> NDArray[np.float64]:
    import cv2

    hull = cv2.convexHull(corners.astype(np.float32)).reshape(-1, 2).astype(np.float64)
    return np.vstack([hull, hull[:1]])


def coverage_png(calibration: CameraCalibration | StereoCalibration) -> bytes:
    """PNG of the corners of every used view over each camera's image frame (one panel per
    camera; colours run through the views in order)."""
    if isinstance(calibration, StereoCalibration):
        fig, axes = _figure(2, 5.6, 4.6)
        _coverage_axes(axes[0], "right (camera 1)", calibration.cam1)
        _coverage_axes(axes[1], "left (camera 2)", calibration.cam2)
    else:
        fig, axes = _figure(1, 6.4, 5.2)
        _coverage_axes(axes[0], "camera", calibration)
    return _png(fig)


def errors_png(calibration: CameraCalibration | StereoCalibration) -> bytes:
    """PNG of the RMS reprojection error of each view (bars) and overall (dashed line)."""
    if isinstance(calibration, StereoCalibration):
        fig, axes = _figure(1, 9.0, 4.2)
        ax = axes[0]
        names = list(calibration.pairs)
        x = np.arange(len(names))
        errors = calibration.per_pair_rms_px
        ax.bar(x - 0.2, errors[:, 0], 0.4, label="right (camera 1)")
        ax.bar(x + 0.2, errors[:, 1], 0.4, label="left (camera 2)")
        ax.axhline(calibration.rms_px, color="black", ls="--", lw=1,
                   label=f"stereo RMS {calibration.rms_px:.3f} px")
        title = (f"stereo fit: per-pair RMS reprojection error ({len(names)} pairs, "
                 f"{len(calibration.skipped)} skipped)")
    else:
        fig, axes = _figure(1, 9.0, 4.2)
        ax = axes[0]
        names = list(calibration.views)
        x = np.arange(len(names))
        ax.bar(x, calibration.per_view_rms_px, 0.6, label="view")
        ax.axhline(calibration.rms_px, color="black", ls="--", lw=1,
                   label=f"overall RMS {calibration.rms_px:.3f} px")
        title = (f"per-view RMS reprojection error ({len(names)} views, "
                 f"{len(calibration.skipped)} skipped)")
    ax.set_xticks(x, names, rotation=90 if len(names) > 12 else 0, fontsize=7)
    ax.set_ylabel("RMS reprojection error (px)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    return _png(fig)


def write_plots(out: str | os.PathLike[str],
                calibration: CameraCalibration | StereoCalibration) -> tuple[Path, Path]:
    """Write :func:`coverage_png` and :func:`errors_png` beside ``out`` (atomically);
    returns their paths."""
    pictures = (coverage_png(calibration), errors_png(calibration))
    paths = plot_paths(out)
    for path, data in zip(paths, pictures, strict=True):
        path.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(path, data)
    return paths
