"""An output folder built whole beside its place, then moved in (:func:`build_folder`): a
failed or interrupted run leaves nothing half-written, and ``overwrite`` replaces only a folder
that the same writer made (its marker file says so). The datasets of
:func:`~photomodel.sim.write_dataset` and the sequences of ``write_sequence(s)`` are written so.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Callable
from pathlib import Path

from photomodel.errors import InputError

__all__ = ["build_folder", "check_out", "is_ours", "remove_stale_partials"]


def is_ours(path: Path, marker: str, fmt: str) -> bool:
    """Whether the folder ``path`` holds the JSON file ``marker`` whose ``format`` is ``fmt``."""
    try:
        data = json.loads((path / marker).read_text())
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and data.get("format") == fmt


def check_out(out: Path, overwrite: bool, marker: str, fmt: str, what: str) -> None:
    """InputError unless :func:`build_folder` may write ``out``: missing, empty, or (with
    ``overwrite``) ``what`` (``"a dataset"``) with its ``marker``; never a file or a link."""
    if out.is_symlink() or (out.exists() and not out.is_dir()):
        raise InputError(out, "exists and is not a directory; choose another --out")
    if out.exists() and any(out.iterdir()):
        if not is_ours(out, marker, fmt):
            raise InputError(out, f"already exists and is not {what} that photomodel "
                                  f"simulate wrote (no {marker}); --force replaces only "
                                  "those: choose another --out")
        if not overwrite:
            raise InputError(out, "already exists and is not empty (use --force to replace it)")


def build_folder(out: Path, marker: str, fmt: str, build: Callable[[Path], None],
                 what: str) -> None:
    """Run ``build`` on a new hidden sibling of ``out`` (``.<name>.partial-<pid>``), then move
    it into place, replacing an ``out`` that is still ours (:func:`is_ours`); nothing is left
    of a failed or interrupted run, not even the folders made for ``out``.

    Raises
    ------
    InputError
        A file cannot be written (``cannot write what: ...``), or ``out`` changed meanwhile
        into something not ours.
    """
    tmp = out.parent / f".{out.name}.partial-{os.getpid()}"
    created = next((p for p in reversed(out.parents) if not p.exists()), None)
    complete = False
    try:
        remove_stale_partials(out)
        if tmp.exists():
            shutil.rmtree(tmp)
        tmp.mkdir(parents=True)
        build(tmp)
        if out.exists():
            if any(out.iterdir()) and not is_ours(out, marker, fmt):  # changed meanwhile
                raise InputError(out, "changed while it was being replaced; left as it is")
            shutil.rmtree(out)
        os.replace(tmp, out)
        complete = True
    except OSError as exc:
        raise InputError(out, f"cannot write {what}: {exc.strerror or exc}") from exc
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
        if not complete and created is not None and created.exists():
            shutil.rmtree(created, ignore_errors=True)


def remove_stale_partials(out: Path) -> None:
    """Remove the half-built folders of earlier runs for ``out`` whose process is gone (a
    ``kill -9`` leaves one)."""
    for partial in out.parent.glob(f".{out.name}.partial-*"):
        pid = partial.name.rsplit("-", 1)[-1]
        if not pid.isdigit() or int(pid) == os.getpid():
            continue
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            shutil.rmtree(partial, ignore_errors=True)
        except OSError:
            pass  # alive (another user's): leave it
