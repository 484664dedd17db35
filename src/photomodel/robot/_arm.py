"""The arm's kinematic model: a Denavit-Hartenberg table with joint limits, from a data file.

The PA10-7C's table lives in ``photomodel/robot/data/pa10_7c.json`` (package data) with the
sources of its numbers. Two sets of link lengths circulate for the PA10; both are in the file and
:func:`load_arm` takes either by name (``link_set``).

Frames: ``base`` (frame 0 of the DH table: origin on the S1 axis at the floor flange, z up along
S1) and ``hand`` (frame 7: the tool flange, z out of the flange). Lengths in mm, angles in
radians; the file holds degrees (the user-facing edge).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from photomodel.errors import InputError
from photomodel.robot._arm_data import ARM_FILES, _arm_file, available_link_sets

__all__ = ["ARM_FILES", "ArmModel", "available_link_sets", "load_arm"]

"""Known arms (name -> data file in ``photomodel/robot/data``)."""


@dataclass(frozen=True)
class ArmModel:
    """A serial arm of revolute joints in standard DH form.

    ``T_{i-1,i}(q_i) = Rz(q_i + offset_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``; ``T_base_hand(q)`` is
    their product over i = 1..n.

    Parameters
    ----------
    name : str
        The arm (e.g. ``"PA10-7C"``).
    link_set : str
        Name of the link lengths used.
    d_mm, a_mm : ndarray (n,)
        DH offsets along z and lengths along x, mm.
    alpha_rad, offset_rad : ndarray (n,)
        DH twists and joint-angle offsets, radians.
    q_min_rad, q_max_rad : ndarray (n,)
        Joint limits, radians.
    joint_names : tuple of str
    sources : dict
        Where the numbers come from (free text per item).
    """

    name: str
    link_set: str
    d_mm: NDArray[np.float64]
    a_mm: NDArray[np.float64]
    alpha_rad: NDArray[np.float64]
    offset_rad: NDArray[np.float64]
    q_min_rad: NDArray[np.float64]
    q_max_rad: NDArray[np.float64]
    joint_names: tuple[str, ...]
    sources: dict[str, str]

    def __post_init__(self) -> None:
        n = len(self.joint_names)
        for key in ("d_mm", "a_mm", "alpha_rad", "offset_rad", "q_min_rad", "q_max_rad"):
            arr = np.asarray(getattr(self, key), dtype=np.float64)
            if arr.shape != (n,):
                raise ValueError(f"{key}: expected shape ({n},), got {arr.shape}")
            if not np.isfinite(arr).all():
                raise ValueError(f"{key}: expected finite numbers")
            arr.setflags(write=False)
            object.__setattr__(self, key, arr)
        if np.any(self.q_min_rad >= self.q_max_rad):
            raise ValueError("q_min_rad: every lower joint limit must lie below the upper one")

    @property
    def n_joints(self) -> int:
        """Number of joints (7 for the PA10-7C)."""
        return len(self.joint_names)

    @property
    def reach_mm(self) -> float:
        """Upper bound of the flange's distance from the first joint offset (sum of |d|, |a|)."""
        return float(np.abs(self.d_mm[1:]).sum() + np.abs(self.a_mm).sum())

    def check_joints(self, q: ArrayLike, source: str = "joints") -> NDArray[np.float64]:
        """Joint angles (n,) in radians as float64, or :class:`InputError` naming ``source``.

        Raises when the count differs from :attr:`n_joints`, a value is not finite, or a value
        lies outside the joint limits.
        """
        arr = np.asarray(q, dtype=np.float64).reshape(-1)
        if arr.shape != (self.n_joints,):
            raise InputError(source, f"expected {self.n_joints} joint angles for the "
                             f"{self.name}, got {arr.size}")
        if not np.isfinite(arr).all():
            raise InputError(source, "joint angles must be finite numbers")
        bad = np.nonzero((arr < self.q_min_rad - 1e-9) | (arr > self.q_max_rad + 1e-9))[0]
        if bad.size:
            i = int(bad[0])
            raise InputError(source, f"joint {self.joint_names[i]} at "
                             f"{np.degrees(arr[i]):.1f} deg is outside its limits "
                             f"[{np.degrees(self.q_min_rad[i]):.0f}, "
                             f"{np.degrees(self.q_max_rad[i]):.0f}] deg")
        return arr

    def within_limits(self, q: ArrayLike, tol_rad: float = 1e-9) -> bool:
        """Whether every joint of ``q`` (n,) lies within its limits (plus ``tol_rad``)."""
        arr = np.asarray(q, dtype=np.float64)
        return bool(np.all(arr >= self.q_min_rad - tol_rad)
                    and np.all(arr <= self.q_max_rad + tol_rad))

    def to_json_dict(self) -> dict[str, Any]:
        """The table in the file's units (mm, degrees)."""
        return {"name": self.name, "link_set": self.link_set, "d_mm": self.d_mm.tolist(),
                "a_mm": self.a_mm.tolist(), "alpha_deg": np.degrees(self.alpha_rad).tolist(),
                "q_min_deg": np.degrees(self.q_min_rad).tolist(),
                "q_max_deg": np.degrees(self.q_max_rad).tolist()}


@lru_cache(maxsize=8)
def load_arm(arm: str = "pa10-7c", link_set: str | None = None) -> ArmModel:
    """The kinematic model of a known arm.

    Parameters
    ----------
    arm : str
        A key of :data:`ARM_FILES` (``"pa10-7c"``).
    link_set : str, optional
        Which link lengths (:func:`available_link_sets`); default: the file's default
        (``"317-450-480-70"`` for the PA10-7C).

    Returns
    -------
    ArmModel
    """
    data = _arm_file(arm)
    name = link_set or data["default_link_set"]
    if name not in data["link_sets"]:
        raise InputError("--link-set", f"unknown link set {name!r} for {data['name']}; "
                         f"known: {', '.join(data['link_sets'])}")
    links = data["link_sets"][name]
    limits = data["joint_limits_deg"]
    return ArmModel(
        name=data["name"], link_set=name,
        d_mm=np.asarray(links["d_mm"], dtype=np.float64),
        a_mm=np.asarray(data["a_mm"], dtype=np.float64),
        alpha_rad=np.radians(data["alpha_deg"]),
        offset_rad=np.radians(data["offset_deg"]),
        q_min_rad=np.radians(limits["lower"]), q_max_rad=np.radians(limits["upper"]),
        joint_names=tuple(data["joint_names"]),
        sources={"links": links["source"], "joint_limits": limits["source"]},
    )
