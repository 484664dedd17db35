"""Entry point and sub-command parsers of the ``photomodel`` command.

Every :class:`~photomodel.errors.PhotomodelError` becomes one line on stderr
(``photomodel: error: FILE: problem``) and exit code 2; nothing is half-written because all
outputs are written atomically after the work succeeded.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from collections.abc import Sequence
from typing import NoReturn

from photomodel import __version__
from photomodel.cli import (
    _audit,
    _build,
    _calibrate,
    _cell,
    _certs,
    _demo,
    _experiment,
    _handeye,
    _identify,
    _locate,
    _models,
    _pick,
    _serve,
    _simulate,
    _track,
    _warmup,
)
from photomodel.errors import PhotomodelError, one_line_input_warnings

EXIT_INPUT_ERROR = 2


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (argparse's names the option and what it
    allows), exit code 2; the sub-command parsers are of this class too."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_INPUT_ERROR, f"photomodel: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with all sub-commands."""
    parser = _Parser(
        prog="photomodel",
        description="Photo-model based garment recognition: build a model from one photo, "
                    "find its 6-DoF pose in a stereo pair.",
    )
    parser.add_argument("--version", action="version", version=f"photomodel {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    parser.commands = sub.choices  # type: ignore[attr-defined]
    _build.add_parser(sub)
    _locate.add_parser(sub)
    _identify.add_parser(sub)
    _track.add_parser(sub)
    _models.add_parser(sub)
    _simulate.add_parser(sub)
    _experiment.add_parser(sub)
    _demo.add_parser(sub)
    _handeye.add_parser(sub)
    _calibrate.add_parser(sub)
    _pick.add_parser(sub)
    _cell.add_parser(sub)
    _serve.add_parser(sub)
    _warmup.add_parser(sub)
    _certs.add_parser(sub)
    _audit.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    # OpenCV's own log (a decoder's complaint about a damaged file) would be a second line;
    # photomodel reports the problem itself. Set before the commands import cv2.
    os.environ.setdefault("OPENCV_LOG_LEVEL", "SILENT")
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    if extra:   # named by the sub-command's parser, whose --help lists what it takes
        commands = getattr(parser, "commands", {})
        commands.get(args.command, parser).error(f"unrecognized arguments: {' '.join(extra)}")
    with warnings.catch_warnings():
        warnings.showwarning = one_line_input_warnings(warnings.showwarning)
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    try:
        return int(args.run(args) or 0)
    except PhotomodelError as exc:
        print(f"photomodel: error: {exc}", file=sys.stderr)
        return EXIT_INPUT_ERROR
    except OSError as exc:  # a file system refusal (permissions, full disk, a file as folder)
        print(f"photomodel: error: {exc.filename or ''}: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_INPUT_ERROR
    except KeyboardInterrupt:
        print("photomodel: interrupted", file=sys.stderr)
        return 130
