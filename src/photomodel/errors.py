"""Error types raised at the library's boundary.

Every error a user can cause by giving a bad file or argument is a :class:`PhotomodelError`;
the CLI turns it into one line on stderr and a non-zero exit code, never a traceback.
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Callable
from os import PathLike
from typing import TextIO

__all__ = ["InputError", "InputWarning", "PhotomodelError", "NoGarmentError"]


class PhotomodelError(Exception):
    """Base class of the errors that the CLI reports as one line without a traceback."""


class InputError(PhotomodelError, ValueError):
    """A file or argument given by the user is missing, unreadable or inconsistent.

    Parameters
    ----------
    source : str or path-like
        The file (or argument name) that is at fault; it starts the message.
    problem : str
        What is wrong with it, in words a user can act on.
    """

    def __init__(self, source: str | PathLike[str], problem: str) -> None:
        self.source = str(source)
        self.problem = problem
        super().__init__(f"{self.source}: {problem}")

    def __reduce__(self) -> tuple[type, tuple[str, str]]:
        # Rebuilt from (source, problem), so that an error raised in a worker process (an
        # experiment's trial) reaches the parent intact instead of breaking the pool.
        return type(self), (self.source, self.problem)


class NoGarmentError(InputError):
    """A model photo in which no garment could be separated from the background."""


class InputWarning(UserWarning):
    """A file that is read but looks wrong (a baseline in metres, damaged image data).

    Raised with :func:`warnings.warn`; the CLI prints it as one line
    (``photomodel: warning: FILE: problem``).

    Parameters
    ----------
    source : str or path-like
        The file (or argument name) that looks wrong; it starts the message.
    problem : str
        What looks wrong with it, in words a user can act on.
    """

    def __init__(self, source: str | PathLike[str], problem: str) -> None:
        self.source = str(source)
        self.problem = problem
        super().__init__(f"{self.source}: {problem}")


def one_line_input_warnings(default: Callable[..., None] | None = None) -> Callable[..., None]:
    """A ``warnings.showwarning`` that prints an :class:`InputWarning` as one line
    (``photomodel: warning: FILE: problem``) and hands other warnings to ``default`` (the
    present ``warnings.showwarning``). The CLI and its worker processes install it."""
    fallback = default or warnings.showwarning

    def show(message: Warning | str, category: type[Warning], filename: str, lineno: int,
             file: TextIO | None = None, line: str | None = None) -> None:
        if issubclass(category, InputWarning):
            print(f"photomodel: warning: {message}", file=sys.stderr)
        else:
            fallback(message, category, filename, lineno, file, line)

    return show
