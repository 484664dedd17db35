"""The ``photomodel`` command line: argument parsing only; the work is in the library."""

from photomodel.cli._main import main

__all__ = ["main"]
