"""``TrackResult``: one frame's answer of a :class:`~photomodel.track.Tracker`."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

from photomodel.locate import LocateResult

__all__ = ["Mode", "TrackResult"]

Mode = Literal["detect", "track", "lost"]

_POSE_KEYS = ("T_cam1_model", "position_mm", "quat_wxyz", "theta_deg")


@dataclass(frozen=True)
class TrackResult(LocateResult):
    """The locate result's fields for one frame, plus how it was measured.

    Attributes
    ----------
    mode : {"detect", "track", "lost"}
        ``detect``: a full search found the garment (the first frame, or after a loss);
        ``track``: refined from the pose the motion model predicted; ``lost``: not found
        (no pose is reported).
    frame : int
        Index of the frame since the tracker was made or reset, from 0.
    t_s : float
        The frame's time, s (given, or the frame index over the frame rate).
    visible : float
        Share of the model's points that the pose puts inside both images (NaN when lost).
    note : str or None
        Why a frame was handled unusually (a timestamp that went backwards, the reason of
        a loss).
    """

    mode: Mode = "detect"
    frame: int = 0
    t_s: float = math.nan
    visible: float = math.nan
    note: str | None = None

    def to_json_dict(self) -> dict[str, Any]:
        """The ``track --json`` object (docs/contracts.md): ``frame``, ``found``, ``mode``,
        ``T_cam1_model``, ``score``, ``seconds`` and the locate fields, ``t_s``,
        ``visible`` and ``note``; the pose fields null when lost."""
        out = {"frame": self.frame, "mode": self.mode, "t_s": self.t_s,
               **super().to_json_dict()}
        out["visible"] = None if math.isnan(self.visible) else self.visible
        out["note"] = self.note
        if self.mode == "lost":
            out.update({key: None for key in _POSE_KEYS})
        return out
