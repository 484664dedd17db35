"""Calibration targets and the ``--pattern`` text that names one: a chessboard, or (where
OpenCV has its aruco module) a ChArUco board, whose corners are identified so that a board
seen in part still counts (:class:`CharucoBoard`).

A chessboard is given by its *inner* corners (OpenCV's ``patternSize``: corners per row,
corners per column) and the side of its squares in mm. Its frame (the target frame): origin
at the first inner corner OpenCV reports, x along the rows, y along the columns, z = x x y
(into the board when the board is seen with x right and y down); z = 0 on the board.

A board with one odd and one even count (9x6, the OpenCV sample board) has a single reading:
its corners are numbered from the inner corner whose outer square (diagonally beyond it) is
white, the square beyond the last corner being black, whichever detector found them
(``findChessboardCornersSB``'s order; the classic detector's is reversed to it). A board whose
two counts have the same parity (7x5, 8x6) looks the same turned by 180 degrees; its corners
are numbered from the end nearer the image's top-left, which is consistent between two
cameras not rolled by more than 45 degrees relative to each other. Prefer an odd-by-even board.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel.errors import InputError

__all__ = ["CharucoBoard", "Chessboard", "Target", "charuco_available", "parse_pattern"]

_MAX_CORNERS_SIDE = 200
_PATTERN = re.compile(r"^\s*chessboard:(\d+)[xX](\d+):([0-9.eE+-]+)\s*$")
_CHARUCO = re.compile(r"^\s*charuco:(\d+)[xX](\d+):([0-9.eE+-]+):([0-9.eE+-]+):(\w+)\s*$",
                      re.IGNORECASE)
_EXAMPLE = "chessboard:COLSxROWS:SQUARE_MM (inner corners), such as chessboard:9x6:25"
_CHARUCO_EXAMPLE = ("charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICT (squares), such as "
                    "charuco:11x8:20:15:DICT_5X5_100")


@dataclass(frozen=True)
class Chessboard:
    """A chessboard calibration target.

    Parameters
    ----------
    inner_corners : (int, int)
        Inner corners per row and per column (OpenCV's ``patternSize``).
    square_mm : float
        Side of a square, mm.
    """

    inner_corners: tuple[int, int]
    square_mm: float

    def __post_init__(self) -> None:
        if min(self.inner_corners) < 2 or self.square_mm <= 0:
            raise ValueError("chessboard: expected at least 2 x 2 inner corners and a positive "
                             "square size")
        object.__setattr__(self, "inner_corners", tuple(int(c) for c in self.inner_corners))
        object.__setattr__(self, "square_mm", float(self.square_mm))

    @property
    def n_corners(self) -> int:
        """Number of inner corners."""
        return self.inner_corners[0] * self.inner_corners[1]

    @property
    def symmetric(self) -> bool:
        """True when the board looks the same turned by 180 degrees (counts of equal parity)."""
        return (self.inner_corners[0] + self.inner_corners[1]) % 2 == 0

    @property
    def name(self) -> str:
        """``"9x6 chessboard"``."""
        return f"{self.inner_corners[0]}x{self.inner_corners[1]} chessboard"

    @property
    def pattern(self) -> str:
        """The ``--pattern`` of ``photomodel calibrate``: ``chessboard:COLSxROWS:SQUARE_MM``."""
        cols, rows = self.inner_corners
        return f"chessboard:{cols}x{rows}:{self.square_mm:g}"

    @property
    def centre_mm(self) -> NDArray[np.float64]:
        """Centre (3,) of the inner corners, target frame, mm."""
        cols, rows = self.inner_corners
        return np.array([(cols - 1) / 2.0, (rows - 1) / 2.0, 0.0]) * self.square_mm

    def object_points(self) -> NDArray[np.float64]:
        """Inner corners (N, 3) in the target frame, mm, in OpenCV's detection order."""
        cols, rows = self.inner_corners
        gx, gy = np.meshgrid(np.arange(cols), np.arange(rows))
        return np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)]) * self.square_mm

    def to_json_dict(self) -> dict[str, Any]:
        """``{"inner_corners": [cols, rows], "square_mm": s}`` (a hand-eye pairs file's
        ``chessboard``)."""
        return {"inner_corners": list(self.inner_corners), "square_mm": self.square_mm}


def charuco_available() -> bool:
    """True when the installed OpenCV has the ``aruco`` module's ChArUco detector."""
    import cv2

    return hasattr(cv2, "aruco") and hasattr(cv2.aruco, "CharucoDetector")


@dataclass(frozen=True)
class CharucoBoard:
    """A ChArUco target: a chessboard whose white squares hold ArUco markers, so that each
    inner corner is identified and a board seen in part still counts.

    Its frame is OpenCV's (``cv2.aruco.CharucoBoard``): origin at the board's outer top-left
    corner, x along the rows, y down the columns, z into the board. Corner ``i`` is the
    ``i``-th inner corner row by row.

    Parameters
    ----------
    squares : (int, int)
        Squares per row and per column (not inner corners: a 11x8 board has 10x7 of them).
    square_mm, marker_mm : float
        Side of a square and of a marker, mm (the marker is the smaller).
    dictionary : str
        The ArUco dictionary's OpenCV name, such as ``DICT_5X5_100``.
    """

    squares: tuple[int, int]
    square_mm: float
    marker_mm: float
    dictionary: str

    def __post_init__(self) -> None:
        if min(self.squares) < 3 or not 0 < self.marker_mm < self.square_mm:
            raise ValueError("charuco: expected at least 3 x 3 squares and a marker smaller "
                             "than the square")
        object.__setattr__(self, "squares", tuple(int(c) for c in self.squares))

    @property
    def inner_corners(self) -> tuple[int, int]:
        return self.squares[0] - 1, self.squares[1] - 1

    @property
    def n_corners(self) -> int:
        return (self.squares[0] - 1) * (self.squares[1] - 1)

    symmetric = False

    @property
    def name(self) -> str:
        return f"{self.squares[0]}x{self.squares[1]} ChArUco board"

    def cv_board(self):  # type: ignore[no-untyped-def]
        """The ``cv2.aruco.CharucoBoard`` (lengths in mm)."""
        import cv2

        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard(self.squares, self.square_mm, self.marker_mm, dictionary)

    def object_points(self) -> NDArray[np.float64]:
        """Inner corners (N, 3) in the board frame, mm, by id."""
        return np.asarray(self.cv_board().getChessboardCorners(), dtype=np.float64)


Target = Chessboard | CharucoBoard
"""A calibration target."""


def _parse_charuco(text: str, option: str) -> CharucoBoard:
    import cv2

    if not charuco_available():
        raise InputError(option, f"this OpenCV ({cv2.__version__}) lacks the aruco module's "
                                 "ChArUco detector; use " + _EXAMPLE)
    m = _CHARUCO.match(text)
    if m is None:
        raise InputError(option, f"expected {_CHARUCO_EXAMPLE}, got {text!r}")
    cols, rows = int(m.group(1)), int(m.group(2))
    name = m.group(5).upper()
    if not name.startswith("DICT_") or not hasattr(cv2.aruco, name):
        raise InputError(option, f"unknown ArUco dictionary {m.group(5)!r} (such as "
                                 "DICT_5X5_100, DICT_4X4_50, DICT_APRILTAG_36H11)")
    try:
        square, marker = float(m.group(3)), float(m.group(4))
    except ValueError:
        raise InputError(option, f"expected {_CHARUCO_EXAMPLE}, got {text!r}") from None
    if not (3 <= cols <= _MAX_CORNERS_SIDE and 3 <= rows <= _MAX_CORNERS_SIDE):
        raise InputError(option, f"expected 3 to {_MAX_CORNERS_SIDE} squares a side, got "
                                 f"{cols}x{rows}")
    if not (np.isfinite(square) and 0 < square <= 1000 and 0 < marker < square):
        raise InputError(option, "expected a square size above 0 and at most 1000 mm and a "
                                 f"smaller marker, got {m.group(3)} and {m.group(4)} mm")
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))
    markers = (cols * rows) // 2
    if markers > dictionary.bytesList.shape[0]:
        raise InputError(option, f"a {cols}x{rows} board needs {markers} markers, more than "
                                 f"{name}'s {dictionary.bytesList.shape[0]}")
    return CharucoBoard((cols, rows), square, marker, name)


def parse_pattern(text: str, option: str = "--pattern") -> Target:
    """The target named by ``chessboard:COLSxROWS:SQUARE_MM`` (COLS x ROWS inner corners) or
    ``charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICT`` (COLS x ROWS squares; where OpenCV has
    the aruco module).

    Raises
    ------
    InputError
        Naming ``option``: not of either form, fewer than 2 (3 squares) or more than 200
        corners a side, a square size that is not a positive number of mm, an unknown
        dictionary.
    """
    if text.strip().lower().startswith("charuco:"):
        return _parse_charuco(text, option)
    m = _PATTERN.match(text)
    if m is None:
        raise InputError(option, f"expected {_EXAMPLE}, or {_CHARUCO_EXAMPLE}; got {text!r}")
    cols, rows = int(m.group(1)), int(m.group(2))
    try:
        square = float(m.group(3))
    except ValueError:
        raise InputError(option, f"the square size {m.group(3)!r} is not a number (mm)") \
            from None
    if not (2 <= cols <= _MAX_CORNERS_SIDE and 2 <= rows <= _MAX_CORNERS_SIDE):
        raise InputError(option, f"expected 2 to {_MAX_CORNERS_SIDE} inner corners a side, got "
                                 f"{cols}x{rows}")
    if not (np.isfinite(square) and 0 < square <= 1000):
        raise InputError(option, f"expected a square size above 0 and at most 1000 mm, got "
                                 f"{m.group(3)}")
    return Chessboard((cols, rows), square)
