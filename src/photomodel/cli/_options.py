"""Options shared by several commands, and range checks: one error line naming the option
and what it allows.

Every check raises :class:`~photomodel.errors.InputError` with the option as its source, so the
command prints ``photomodel: error: --seed: expected an integer from 0 to 4294967295, got -1``
and exits with code 2, before anything is written. Nothing heavy is imported here at module
level (the parsers are built for ``--help``).
"""

from __future__ import annotations

import argparse
import math
import re
from pathlib import Path
from typing import TYPE_CHECKING

from photomodel.errors import InputError, PhotomodelError

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    from photomodel.camera import StereoRig

SEED_MAX = 2**32 - 1
"""Largest seed (seeds are 32-bit, as numpy's legacy seeding and most tools take them)."""


def add_stereo_options(parser: argparse.ArgumentParser | argparse._ArgumentGroup, *,
                       pair: bool = True, required: bool = True, prefix: str = "") -> None:
    """Add ``--stereo`` (the hand rig's calibration file) and, with ``pair``, ``--right`` and
    ``--left`` (camera 1's and camera 2's image), each a :class:`~pathlib.Path`; ``prefix``
    starts each help text (``"in place: "``). Read them with :func:`load_stereo_pair`."""
    parser.add_argument("--stereo", required=required, type=Path,
                        help=f"{prefix}the hand rig's stereo calibration (K1, D1, K2, D2, R, "
                             f"T; camera 1 = right)")
    if pair:
        parser.add_argument("--right", required=required, type=Path,
                            help=f"{prefix}camera 1 (right) image")
        parser.add_argument("--left", required=required, type=Path,
                            help=f"{prefix}camera 2 (left) image")


def load_stereo_pair(args: argparse.Namespace
                     ) -> tuple[StereoRig, NDArray[np.uint8], NDArray[np.uint8]]:
    """The rig of ``args.stereo`` and the images of ``args.right`` and ``args.left`` (BGR,
    (H, W, 3) uint8), their sizes checked against the rig's cameras; errors name the file."""
    from photomodel.camera import load_stereo
    from photomodel.image import read_color_image

    rig = load_stereo(args.stereo)
    right = read_color_image(args.right)
    left = read_color_image(args.left)
    rig.cam1.check_image(right, str(args.right))
    rig.cam2.check_image(left, str(args.left))
    return rig, right, left


def check_int(option: str, value: int, lo: int, hi: int | None = None) -> int:
    """``value`` if ``lo <= value (<= hi)``, else InputError naming ``option`` and the range."""
    if value < lo or (hi is not None and value > hi):
        allowed = f"from {lo} to {hi}" if hi is not None else f"of at least {lo}"
        raise InputError(option, f"expected an integer {allowed}, got {value}")
    return value


def check_float(option: str, value: float, lo: float, hi: float, *, lo_open: bool = False,
                unit: str = "") -> float:
    """``value`` if finite and within [lo, hi] (``(lo, hi]`` with ``lo_open``), else
    InputError naming ``option`` and the range in its unit."""
    ok = math.isfinite(value) and (value > lo if lo_open else value >= lo) and value <= hi
    if not ok:
        unit = f" {unit}" if unit else ""
        allowed = (f"greater than {lo:g} and at most {hi:g}{unit}" if lo_open
                   else f"from {lo:g} to {hi:g}{unit}")
        raise InputError(option, f"expected a number {allowed}, got {value:g}")
    return value


def check_seed(value: int, option: str = "--seed") -> int:
    """A seed: an integer from 0 to :data:`SEED_MAX`."""
    return check_int(option, value, 0, SEED_MAX)


_ADDRESS = re.compile(r"^(?:(tcp|tls|ucx|ws|wss|inproc)://)?"
                      r"(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+)(?::(\d{1,5}))?/?$")


def check_scheduler(address: str) -> str:
    """A Dask scheduler address (``tcp://host:8786``, ``host:8786``, ``tls://...``)."""
    m = _ADDRESS.match(address.strip())
    if m is None or (m.group(3) is None and m.group(1) != "inproc") or (
            m.group(3) is not None and not 0 < int(m.group(3)) < 65536):
        raise InputError("--scheduler", f"expected a Dask scheduler address such as "
                                        f"tcp://host:8786, got {address!r}")
    return address.strip()


def as_option_error(exc: ValueError, options: dict[str, str], fallback: str) -> InputError:
    """An InputError for a settings object's ValueError (``"key: problem"``), with the source
    the option of ``key`` (``options``: key -> option), else ``fallback``; an InputError is
    returned unchanged (its source is already right)."""
    if isinstance(exc, PhotomodelError):
        return exc  # type: ignore[return-value]
    text = str(exc)
    key, sep, rest = text.partition(": ")
    if sep and key in options:
        return InputError(options[key], rest)
    return InputError(fallback, text)
