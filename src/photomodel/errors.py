"""Error types raised at the library's boundary.

Every error a user can cause by giving a bad file or argument is a :class:`PhotomodelError`;
the CLI turns it into one line on stderr and a non-zero exit code, never a traceback.
"""

from __future__ import annotations

from os import PathLike

__all__ = ["InputError", "PhotomodelError", "NoGarmentError"]


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


class NoGarmentError(InputError):
    """A model photo in which no garment could be separated from the background."""
