"""A model library: a directory of photo-model files, with an index that caches them.

Layout::

    DIR/<any name>     one self-contained photo-model each (:func:`photomodel.model.save_model`;
                       ``photomodel build --out DIR/shirt.model`` and ``models add``, which
                       writes ``DIR/<name>.npz``, make them), named by the name it holds
    DIR/index.json     {"format": "photomodel-library", "version": 1,
                        "models": {"<name>": {"file", "size_mm", "area_mm2", "colours",
                                              "n_in", "n_out", "created_utc", "added_utc",
                                              "file_bytes", "file_mtime_ns", "descriptor"}}}
    DIR/labels.json    optional: the label map, {"format": "photomodel-labels", "version": 1,
                        "labels": {"<label text>": "<model name>"}}

The model files are the truth; the index caches what listing needs (name, size, main colours,
dates) and each model's descriptor (:class:`~photomodel.model.ModelDescriptor`, what
identification screens a catalogue with), so that neither ``models list`` nor ``identify``
opens every file. A directory of model files without an index is a library too.
:meth:`ModelLibrary.scan` reconciles the two: an indexed file that is unchanged (same byte
count and modification time) is taken from the index and any other file of the directory is
opened (a model file is a NumPy archive whatever its ending: ``.npz``, ``.model`` or none);
a file that is not a readable photo-model (a README, a photo, a corrupt, foreign or newer
model file), a model whose name another file already has, or an index entry whose file is
gone is *skipped* with a :class:`Skipped` note naming it, whatever is wrong with the file (one
bad file never makes the library unusable). Not looked at: sub-folders, hidden files (the
lock, temporaries), the library's own ``index.json`` and ``threshold.json``, and the
``*.preview.png`` pictures ``photomodel build`` writes beside a model. Of two files holding
one name, the one the index lists under it is used, else the first by file name; the note
on the other names both. The index is written atomically (temporary file, then rename) by
:meth:`ModelLibrary.add`, :meth:`ModelLibrary.remove` and :meth:`ModelLibrary.reindex`, never
by a read (a read of files the index does not vouch for describes them in memory), and each
of them reads, changes and writes the index holding an exclusive lock on
``DIR/.index.lock`` (``fcntl.flock``; released by the kernel when the process dies), so that
concurrent writers (several ``photomodel models add``, the service) never lose each other's
entries. Readers need no lock: they see the old index or the new one, never a torn one.
An index written before descriptors existed (or holding one that does not parse, which is
noted) is upgraded by :meth:`ModelLibrary.described`: the missing descriptors are computed from
the model files and the index rewritten under the lock, every other entry kept as it was.

The label map (``photomodel models label NAME CODE``) names the model a garment's barcode,
QR code or DataMatrix stands for (:meth:`ModelLibrary.labels`, read by
:class:`~photomodel.Identifier`); :meth:`ModelLibrary.set_label` and
:meth:`ModelLibrary.remove_label` change it under the same lock and write it the same way,
and only for a model the library holds; removing a model drops its labels.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import json
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel._files import write_atomic
from photomodel.errors import InputError
from photomodel.model import ModelDescriptor, PhotoModel, describe_model, load_model, save_model

__all__ = [
    "INDEX_NAME",
    "LABELS_NAME",
    "LIBRARY_FORMAT_VERSION",
    "LOOKED_FOR",
    "LibraryEntry",
    "LibraryScan",
    "ModelLibrary",
    "Skipped",
    "check_label_code",
    "check_model_name",
    "main_colours",
]

INDEX_NAME = "index.json"
LIBRARY_FORMAT_VERSION = 1
MAX_NAME_CHARS = 100
"""Longest model name (the file name ``<name>.npz`` and its preview must fit a file system's
255 bytes)."""
LOOKED_FOR = ("photo-model files of any name, such as NAME.model or NAME.npz, as photomodel "
              "build --out DIR/NAME.model and photomodel models add write them")
"""What a scan looks for, for messages about a library without models."""
_LOCK_NAME = ".index.lock"
_FORMAT = "photomodel-library"
LABELS_NAME = "labels.json"
LABELS_FORMAT_VERSION = 1
MAX_LABEL_CHARS = 500
"""Longest label text in the map."""
_LABELS_FORMAT = "photomodel-labels"
_OWN_FILES = frozenset({INDEX_NAME, LABELS_NAME, "threshold.json"})
"""The library's own files (``threshold.json``: :data:`photomodel.locate.THRESHOLD_FILE`),
never read as models."""
_PREVIEW_ENDING = ".preview.png"
"""The picture ``photomodel build`` writes beside a model file: not looked at."""
_BAD_NAME_CHARS = set('/\\:*?"<>|')


@dataclass(frozen=True)
class LibraryEntry:
    """One model of the library, as the index describes it.

    Attributes
    ----------
    name : str
        Model name (unique in the library).
    file : str
        File name inside the library directory.
    size_mm : (float, float)
        Width and height of the outline's bounding box, mm.
    area_mm2 : float
        Area of the silhouette, mm^2.
    colours : tuple of (str, float)
        Main colours of the garment: sRGB hex (``"#rrggbb"``) and share of its pixels, largest
        first.
    n_in, n_out : int
        Numbers of S_in and S_out points.
    created_utc : str
        When the model was built (ISO 8601; empty if the file does not say).
    added_utc : str
        When it entered the library (ISO 8601; a file the index does not list yet: its
        modification time).
    file_bytes, file_mtime_ns : int
        Size and modification time of the file when it was indexed.
    descriptor : ModelDescriptor or None
        What identification screens with; None until described (an index of an older
        photomodel, or an unreadable descriptor).
    """

    name: str
    file: str
    size_mm: tuple[float, float]
    area_mm2: float
    colours: tuple[tuple[str, float], ...]
    n_in: int
    n_out: int
    created_utc: str
    added_utc: str
    file_bytes: int
    file_mtime_ns: int
    descriptor: ModelDescriptor | None = None

    def to_json_dict(self) -> dict[str, Any]:
        """The entry as stored in ``index.json`` (without its name, which is the key)."""
        d: dict[str, Any] = {
            "file": self.file, "size_mm": list(self.size_mm), "area_mm2": self.area_mm2,
            "colours": [list(c) for c in self.colours], "n_in": self.n_in, "n_out": self.n_out,
            "created_utc": self.created_utc, "added_utc": self.added_utc,
            "file_bytes": self.file_bytes, "file_mtime_ns": self.file_mtime_ns}
        if self.descriptor is not None:
            d["descriptor"] = self.descriptor.to_json_dict()
        return d

    @classmethod
    def from_json_dict(cls, name: str, d: dict[str, Any]) -> LibraryEntry:
        """Inverse of :meth:`to_json_dict`; ValueError/KeyError/TypeError when malformed
        (a malformed ``descriptor`` too: :meth:`ModelLibrary.scan` reads the entry without
        it and notes why)."""
        descriptor = d.get("descriptor")
        return cls(
            name=str(name), file=str(d["file"]),
            size_mm=(float(d["size_mm"][0]), float(d["size_mm"][1])),
            area_mm2=float(d["area_mm2"]),
            colours=tuple((str(c[0]), float(c[1])) for c in d["colours"]),
            n_in=int(d["n_in"]), n_out=int(d["n_out"]), created_utc=str(d["created_utc"]),
            added_utc=str(d["added_utc"]), file_bytes=int(d["file_bytes"]),
            file_mtime_ns=int(d["file_mtime_ns"]),
            descriptor=None if descriptor is None else ModelDescriptor.from_json_dict(descriptor))


@dataclass(frozen=True)
class Skipped:
    """A file (or index entry) of the library that was left out, and why."""

    path: Path
    reason: str

    def __str__(self) -> str:
        return f"{_printable(str(self.path))}: skipped: {_printable(self.reason)}"


@dataclass(frozen=True)
class LibraryScan:
    """What :meth:`ModelLibrary.scan` found: usable entries (by name order) and skipped files."""

    entries: tuple[LibraryEntry, ...]
    skipped: tuple[Skipped, ...]


def main_colours(model: PhotoModel, count: int = 3, min_share: float = 0.05
                 ) -> tuple[tuple[str, float], ...]:
    """The garment's main colours from its model photo.

    Pixels of the mask are binned into 4 levels per BGR channel (64 bins); the ``count`` most
    populated bins holding at least ``min_share`` of the pixels give their mean colour.

    Returns
    -------
    tuple of (str, float)
        ``("#rrggbb", share)``, largest share first (deterministic).
    """
    pixels: NDArray[np.uint8] = model.photo_bgr[model.mask.astype(bool)]
    if len(pixels) == 0:
        return ()
    q = (pixels // 64).astype(np.int64)
    bins = q[:, 0] * 16 + q[:, 1] * 4 + q[:, 2]
    counts = np.bincount(bins, minlength=64)
    out: list[tuple[str, float]] = []
    for b in np.argsort(-counts, kind="stable")[:count]:
        share = counts[b] / len(pixels)
        if share < min_share:
            break
        blue, green, red = pixels[bins == b].mean(axis=0).round().astype(int)
        out.append((f"#{red:02x}{green:02x}{blue:02x}", round(float(share), 3)))
    return tuple(out)


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def _utc(seconds: float) -> str:
    """A file time (seconds since the epoch) as :func:`_now` writes times: an un-indexed
    file entered the library when it was written there."""
    return _dt.datetime.fromtimestamp(seconds, _dt.UTC).isoformat(timespec="seconds")


def _printable(text: str) -> str:
    """``text`` itself if it prints as one plain line, else its escaped form (``ascii``)."""
    return text if text.isprintable() else ascii(text)[1:-1]


def _name_problem(name: str) -> str | None:
    """Why ``name`` cannot be a model name of a library, or None when it can."""
    if not isinstance(name, str) or not name.strip():
        return "a model name must not be empty"
    if not name.isprintable() or name != name.strip():
        return ("a model name must be printable characters only (no line breaks, control or "
                "direction characters, no leading or trailing spaces)")
    if name.startswith(".") or any(c in _BAD_NAME_CHARS for c in name):
        return 'a model name must not start with a dot or hold any of / \\ : * ? " < > |'
    if len(name) > MAX_NAME_CHARS or len(name.encode("utf-8")) > 2 * MAX_NAME_CHARS:
        return f"a model name must be at most {MAX_NAME_CHARS} characters long"
    return None


def check_model_name(name: str, source: str = "name") -> str:
    """``name`` if it can be a model name of a library, else InputError naming ``source``.

    A name is printable characters only (``str.isprintable``: no line break, control or
    bidirectional-override character that would garble a listing), without leading or trailing
    spaces, without path separators or a leading dot (it becomes the file name
    ``<name>.npz``), and at most :data:`MAX_NAME_CHARS` characters long.
    """
    problem = _name_problem(name)
    if problem is not None:
        text = str(name)
        shown = repr(text) if len(text) <= 2 * MAX_NAME_CHARS else f"{text[:40]!r}..."
        raise InputError(source, f"{shown} cannot be a model name in a library: {problem}")
    return name


def check_label_code(code: str, source: str = "code") -> str:
    """``code`` if it can be a label's text in a label map, else InputError naming
    ``source``: 1 to :data:`MAX_LABEL_CHARS` printable characters (what a reader reports of
    a barcode, QR code or DataMatrix; no line break or control character)."""
    if not isinstance(code, str) or not code:
        raise InputError(source, "a label code must not be empty")
    if not code.isprintable() or len(code) > MAX_LABEL_CHARS:
        shown = ascii(code[:60]) + ("..." if len(code) > 60 else "")
        raise InputError(source, f"{shown} cannot be a label code: at most {MAX_LABEL_CHARS} "
                                 "printable characters (no line breaks or control characters)")
    return code


def _write_json(path: Path, data: Any) -> None:
    """Replace ``path`` with ``data`` as JSON, atomically and flushed to disk
    (:func:`~photomodel._files.write_atomic`; call holding :meth:`ModelLibrary._locked`)."""
    write_atomic(path, (json.dumps(data, indent=1) + "\n").encode())


class ModelLibrary:
    """A directory of photo-model files, with an index that caches them (see the module
    docstring; a directory of model files without an index is a library too).

    Parameters
    ----------
    root : path
        The library directory.
    create : bool
        Create it (and its empty index) when missing; otherwise a missing directory is an
        :class:`~photomodel.errors.InputError`.
    """

    def __init__(self, root: str | os.PathLike[str], *, create: bool = False) -> None:
        self.root = Path(root)
        if not self.root.is_dir():
            if not create:
                if self.root.exists():
                    raise InputError(self.root, "is not a directory")
                raise InputError(self.root, "model library directory not found")
            try:
                self.root.mkdir(parents=True, exist_ok=True)  # another writer may race us
            except FileExistsError:
                raise InputError(self.root, "is not a directory") from None
            except OSError as exc:
                raise InputError(self.root, f"cannot create it ({exc.strerror})") from None

    @property
    def index_path(self) -> Path:
        """``DIR/index.json``."""
        return self.root / INDEX_NAME

    # --- the index ---------------------------------------------------------------------------

    @contextlib.contextmanager
    def _locked(self) -> Iterator[None]:
        """Hold the library's write lock (``DIR/.index.lock``, exclusive ``flock``) inside.

        The kernel releases it when the process ends, however it ends, so a killed writer never
        leaves the library locked. Temporaries found under the lock are killed writers'
        leftovers and are removed (:meth:`_remove_leftovers`).
        """
        try:
            import fcntl
        except ImportError:  # not POSIX: no lock (the index write stays atomic)
            yield
            return
        try:
            fd = os.open(self.root / _LOCK_NAME, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise InputError(self.root, f"cannot write to the library ({exc.strerror})") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            self._remove_leftovers()
            yield
        finally:
            os.close(fd)  # releases the lock

    def _remove_leftovers(self) -> None:
        """Remove what killed writers left (call holding the lock): every index and label map
        temporary, and model temporaries (``.<name>.npz.tmp-<pid>-<thread>``, and
        ``.<name>.npz.tmp`` as earlier versions named them; likewise ``.model``) older
        than a minute (a ``photomodel build --out`` straight into the directory, which takes
        no lock, may be writing a young one)."""
        for own in (INDEX_NAME, LABELS_NAME):
            for stale in self.root.glob(f".{own}.tmp-*"):
                stale.unlink(missing_ok=True)
        now = time.time()
        for stale in (*self.root.glob(".*.npz.tmp*"), *self.root.glob(".*.model.tmp*")):
            with contextlib.suppress(OSError):
                if now - stale.stat().st_mtime > 60.0:
                    stale.unlink()

    def _read_index(self) -> tuple[dict[str, LibraryEntry], list[Skipped]]:
        """Entries of ``index.json`` (empty if missing); a damaged index is noted and ignored,
        and so is an entry whose name cannot be a model name."""
        path = self.index_path
        if not path.exists():
            return {}, []
        try:
            data = json.loads(path.read_text())
            if not isinstance(data, dict) or data.get("format") != _FORMAT:
                raise ValueError("not a photomodel library index")
            if int(data.get("version", -1)) > LIBRARY_FORMAT_VERSION:
                raise ValueError(f"index version {data.get('version')} is newer than this "
                                 f"photomodel reads ({LIBRARY_FORMAT_VERSION})")
            entries, notes = {}, []
            for name, d in dict(data.get("models", {})).items():
                if _name_problem(name) is None:   # otherwise its file is read (and skipped)
                    try:
                        entries[str(name)] = LibraryEntry.from_json_dict(name, d)
                    except ValueError as exc:
                        if "descriptor" not in str(exc) or not isinstance(d, dict):
                            raise
                        entries[str(name)] = LibraryEntry.from_json_dict(
                            name, {**d, "descriptor": None})
                        notes.append(Skipped(path, f"descriptor of {_printable(name)!r} "
                                                   f"ignored ({str(exc)[:160]}); it is "
                                                   "described again from its file"))
            return entries, notes
        except Exception as exc:  # noqa: BLE001 - whatever is wrong with it, the files decide
            return {}, [Skipped(path, f"index ignored, models read from their files "
                                      f"({type(exc).__name__}: {str(exc)[:200]})")]

    def _write_index(self, entries: dict[str, LibraryEntry]) -> None:
        """Replace ``index.json`` atomically (call holding :meth:`_locked`)."""
        _write_json(self.index_path, {
            "format": _FORMAT, "version": LIBRARY_FORMAT_VERSION,
            "models": {n: entries[n].to_json_dict() for n in sorted(entries)}})

    # --- reading -----------------------------------------------------------------------------

    def _entry_for(self, path: Path, model: PhotoModel, added_utc: str) -> LibraryEntry:
        st = path.stat()
        return LibraryEntry(
            name=model.name, file=path.name, size_mm=model.size_mm, area_mm2=model.area_mm2,
            colours=main_colours(model), n_in=model.n_in, n_out=model.n_out,
            created_utc=str(model.meta.get("created_utc", "")), added_utc=added_utc,
            file_bytes=int(st.st_size), file_mtime_ns=int(st.st_mtime_ns),
            descriptor=describe_model(model))

    def _files(self) -> list[Path]:
        """The directory's files that may be models (see the module docstring), by name."""
        try:
            paths = sorted(self.root.iterdir())
        except OSError as exc:
            raise InputError(self.root, f"cannot list the library ({exc.strerror})") from None
        return [p for p in paths
                if not (p.name.startswith(".") or p.name in _OWN_FILES
                        or p.name.endswith(_PREVIEW_ENDING)) and p.is_file()]

    def scan(self) -> LibraryScan:
        """The usable models and the skipped files (reads only what the index cannot vouch for).

        Every file of the directory that may be a model is considered (any file name: a
        model file is an archive whatever its ending); a file the index lists, unchanged, is
        taken from the index, any other is opened and described in memory (the index is left
        as it is: writers update it). Of two files holding one model name, the one the index
        lists under that name is used, else the first by file name; the other is skipped
        with a note naming both.

        Returns
        -------
        LibraryScan
        """
        indexed, skipped = self._read_index()
        by_file = {e.file: e for e in indexed.values()}
        found: list[LibraryEntry] = []
        for path in self._files():
            try:
                st = path.stat()
                cached = by_file.get(path.name)
                if (cached is not None and cached.file_bytes == st.st_size
                        and cached.file_mtime_ns == st.st_mtime_ns):
                    entry = cached
                else:
                    model = _load_one(path)
                    entry = self._entry_for(path, model, cached.added_utc if cached is not None
                                            else _utc(st.st_mtime))
            except Exception as exc:  # noqa: BLE001 - one bad file must not sink the library
                skipped.append(Skipped(path, _why(exc)))
                continue
            found.append(entry)

        def precedence(e: LibraryEntry) -> tuple[bool, str]:   # the indexed file, then by name
            listed = indexed.get(e.name)
            return (listed is None or listed.file != e.file, e.file)

        entries: dict[str, LibraryEntry] = {}
        for entry in sorted(found, key=precedence):
            used = entries.setdefault(entry.name, entry)
            if used is not entry:
                skipped.append(Skipped(self.root / entry.file, _duplicate(entry.name, used.file)))
        for e in indexed.values():
            if not (self.root / e.file).is_file():
                skipped.append(Skipped(self.root / e.file,
                                       f"listed in {INDEX_NAME} as {e.name!r} but the file is "
                                       "missing"))
        return LibraryScan(tuple(entries[n] for n in sorted(entries)), tuple(skipped))

    def described(self) -> LibraryScan:
        """:meth:`scan`, every entry with its descriptor.

        Entries the index holds without one (an index of an older photomodel, an unreadable
        descriptor) are described from their files, and the index is rewritten with them
        under the lock, every other entry as it was; a library that cannot be written (read
        only) is described in memory only, with a note. A file that no longer loads is
        skipped with a note.
        """
        scan = self.scan()
        if all(e.descriptor is not None for e in scan.entries):
            return scan
        try:
            with self._locked():
                scan = self.scan()
                entries, skipped = self._describe(scan)
                try:
                    self._write_index({e.name: e for e in entries})
                except OSError as exc:
                    skipped.append(Skipped(self.index_path, "cannot be upgraded with "
                                           f"descriptors ({exc.strerror or exc}); described "
                                           "in memory"))
        except InputError as exc:      # no lock: a read-only library
            entries, skipped = self._describe(scan)
            skipped.append(Skipped(self.index_path, f"not upgraded with descriptors "
                                                    f"({exc.problem}); described in memory"))
        return LibraryScan(tuple(entries), tuple(skipped))

    def _describe(self, scan: LibraryScan) -> tuple[list[LibraryEntry], list[Skipped]]:
        """The scan's entries, each with a descriptor (computed from its file where missing),
        and the notes (files that no longer load are left out)."""
        entries, skipped = [], list(scan.skipped)
        for e in scan.entries:
            if e.descriptor is None:
                path = self.root / e.file
                try:
                    e = replace(e, descriptor=describe_model(_load_one(path)))
                except Exception as exc:  # noqa: BLE001 - one bad file must not sink the library
                    skipped.append(Skipped(path, _why(exc)))
                    continue
            entries.append(e)
        return entries, skipped

    def load(self, names: list[str] | None = None) -> tuple[list[PhotoModel], list[Skipped]]:
        """Load the library's models (all, or those named), with the files skipped.

        A file that changed since the scan and no longer loads is skipped too.

        Raises
        ------
        InputError
            A name in ``names`` that the library does not hold.
        """
        scan = self.scan()
        by_name = {e.name: e for e in scan.entries}
        wanted = list(by_name) if names is None else names
        missing = [n for n in wanted if n not in by_name]
        if missing:
            raise InputError(self.root, f"no model named {missing[0]!r} in the library")
        models, skipped = [], list(scan.skipped)
        for name in wanted:
            path = self.root / by_name[name].file
            try:
                models.append(_load_one(path))
            except Exception as exc:  # noqa: BLE001 - one bad file must not sink the library
                skipped.append(Skipped(path, _why(exc)))
        return models, skipped

    def load_entry(self, entry: LibraryEntry) -> PhotoModel:
        """The model of one entry (of :meth:`scan` or :meth:`described`), read from its file.

        Raises
        ------
        InputError
            The file is gone or no longer a readable photo-model of that name.
        """
        path = self.root / entry.file
        try:
            model = _load_one(path)
        except Exception as exc:  # noqa: BLE001 - said in one line, whatever it is
            raise InputError(path, _why(exc)) from None
        if model.name != entry.name:
            raise InputError(path, f"holds model {model.name!r}, not {entry.name!r} (the "
                                   "library changed: reopen it)")
        return model

    def entry(self, name: str) -> LibraryEntry:
        """The entry of model ``name``; InputError when there is none."""
        for e in self.scan().entries:
            if e.name == name:
                return e
        raise InputError(self.root, f"no model named {name!r} in the library")

    # --- writing -----------------------------------------------------------------------------

    def add(self, model_path: str | os.PathLike[str], name: str | None = None, *,
            replace: bool = False) -> LibraryEntry:
        """Copy a model file into the library as ``DIR/<name>.npz`` and index it.

        Parameters
        ----------
        model_path : path
            A photo-model file (``photomodel build``'s output).
        name : str, optional
            Name in the library (default: the model's own); the stored model takes it.
        replace : bool
            Replace a model of the same name (otherwise that is an error).

        Raises
        ------
        InputError
            Unreadable model file, a bad or taken name.
        """
        if name is not None:
            check_model_name(name)
        model = load_model(model_path)
        if name is not None and name != model.name:
            model = PhotoModel(**{**model.__dict__, "name": name})
        check_model_name(model.name, str(model_path) if name is None else "name")
        return self.add_model(model, replace=replace)

    def add_model(self, model: PhotoModel, *, replace: bool = False) -> LibraryEntry:
        """Save ``model`` into the library as ``DIR/<model.name>.npz`` and index it (what
        :meth:`add` does after reading its file; a service registering a garment calls it).

        Raises
        ------
        InputError
            A bad or taken name.
        """
        check_model_name(model.name)
        with self._locked():   # read, change and write the index as one step
            scan = self.scan()
            taken = {e.name: e for e in scan.entries}
            if model.name in taken and not replace:
                raise InputError(self.root, f"already holds a model named {model.name!r} "
                                            "(use --replace to replace it)")
            target = self.root / f"{model.name}.npz"
            if model.name not in taken and target.exists():
                holder = next((e.name for e in scan.entries if e.file == target.name), None)
                if holder is not None:   # a model file named after another model
                    raise InputError(target, f"holds the library's model {holder!r}; add "
                                             "this one under another name, or rename that "
                                             "file first")
                raise InputError(target, "exists but is not a usable model of this library; "
                                         "remove it first")
            old = taken.get(model.name)
            if old is not None and old.file != target.name:
                (self.root / old.file).unlink(missing_ok=True)
            save_model(model, target)
            entries = {e.name: e for e in scan.entries}
            entries[model.name] = self._entry_for(target, model, _now())
            self._write_index(entries)
        return entries[model.name]

    def remove(self, name: str) -> LibraryEntry:
        """Delete model ``name``'s file and its index entry, and the labels naming it (a
        label map that cannot be read is left as it is); InputError when there is none."""
        with self._locked():
            scan = self.scan()
            entries = {e.name: e for e in scan.entries}
            if name not in entries:
                raise InputError(self.root, f"no model named {name!r} in the library")
            gone = entries.pop(name)
            self._write_index(entries)
            (self.root / gone.file).unlink(missing_ok=True)
            with contextlib.suppress(InputError):
                labels = self.labels()
                if name in labels.values():
                    self._write_labels({c: n for c, n in labels.items() if n != name})
        return gone

    # --- the label map -----------------------------------------------------------------------

    @property
    def labels_path(self) -> Path:
        """``DIR/labels.json``."""
        return self.root / LABELS_NAME

    def labels(self) -> dict[str, str]:
        """The label map: a label's text (barcode, QR code, DataMatrix) -> the model it names.

        Returns
        -------
        dict of str to str
            Empty when the library has no ``labels.json``.

        Raises
        ------
        InputError
            ``labels.json`` cannot be read or is not a label map (one line naming it).
        """
        path = self.labels_path
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            return {}
        except (OSError, UnicodeDecodeError) as exc:
            raise InputError(path, f"cannot read the label map ({_why_text(exc)})") from None
        try:
            data = json.loads(text)
            if not isinstance(data, dict) or data.get("format") != _LABELS_FORMAT:
                raise ValueError(f"expected a JSON object with \"format\": \"{_LABELS_FORMAT}\"")
            version = data.get("version")
            if isinstance(version, bool) or not isinstance(version, int):
                raise ValueError(f"version: expected an integer, got {version!r}"[:120])
            if version > LABELS_FORMAT_VERSION:
                raise ValueError(f"version {version} is newer than this photomodel reads "
                                 f"({LABELS_FORMAT_VERSION})")
            labels = data.get("labels")
            if not isinstance(labels, dict):
                raise ValueError("labels: expected an object of label text -> model name")
            for code, name in labels.items():
                check_label_code(code, "label")
                if not isinstance(name, str) or _name_problem(name) is not None:
                    raise ValueError(f"label {code[:60]!r} names {str(name)[:60]!r}, which "
                                     "cannot be a model name")
        except (ValueError, InputError) as exc:
            problem = exc.problem if isinstance(exc, InputError) else str(exc)
            raise InputError(path, f"not a photomodel label map ({_printable(problem)[:200]}); "
                                   "fix or remove it") from None
        return dict(labels)

    def _write_labels(self, labels: dict[str, str]) -> None:
        """Replace ``labels.json`` atomically (call holding :meth:`_locked`)."""
        _write_json(self.labels_path, {"format": _LABELS_FORMAT,
                                       "version": LABELS_FORMAT_VERSION,
                                       "labels": {c: labels[c] for c in sorted(labels)}})

    def set_label(self, code: str, name: str, *, replace: bool = False) -> str | None:
        """Let label text ``code`` name model ``name`` (``photomodel models label NAME CODE``).

        Parameters
        ----------
        code : str
            What the label encodes (:func:`check_label_code`).
        name : str
            A model of the library.
        replace : bool
            Move a label that names another model to ``name`` (otherwise that is an error).

        Returns
        -------
        str or None
            The model ``code`` named before (``name`` itself when nothing changed), None when
            it was not in the map.

        Raises
        ------
        InputError
            A bad code, a model the library does not hold, a code that names another model
            (without ``replace``), an unreadable label map; nothing is written then.
        """
        check_label_code(code)
        with self._locked():
            names = {e.name for e in self.scan().entries}
            if name not in names:
                raise InputError(self.root, f"no model named {str(name)[:100]!r} in the "
                                            "library: a label must name one of its models "
                                            "(photomodel models list)")
            labels = self.labels()
            old = labels.get(code)
            if old is not None and old != name and not replace:
                raise InputError(self.labels_path, f"label {code[:100]!r} already names model "
                                                   f"{old!r} (use --replace to move it to "
                                                   f"{name!r})")
            if old != name:
                labels[code] = name
                self._write_labels(labels)
        return old

    def remove_label(self, code: str) -> str:
        """Drop label text ``code`` from the map; the model it named. InputError when the
        map does not hold it (or cannot be read); nothing is written then."""
        with self._locked():
            labels = self.labels()
            if code not in labels:
                raise InputError(self.labels_path if self.labels_path.exists() else self.root,
                                 f"no label {str(code)[:100]!r} in the label map")
            name = labels.pop(code)
            self._write_labels(labels)
        return name

    def reindex(self) -> LibraryScan:
        """Rewrite ``index.json`` from the files (skipped files stay out); returns the scan."""
        with self._locked():
            scan = self.scan()
            self._write_index({e.name: e for e in scan.entries})
        return scan


def _load_one(path: Path) -> PhotoModel:
    """One library file's model; InputError when its name cannot be a library's."""
    model = load_model(path)
    problem = _name_problem(model.name)
    if problem is not None:
        raise InputError(path, f"model name {model.name[:60]!r}: {problem}")
    return model


def _duplicate(name: str, used: str) -> str:
    """The note on a file whose model name the file ``used`` holds too."""
    return (f"model name {name!r} is already taken by {used}, which the library uses (move "
            "this file out, or add it under another name with photomodel models add --name)")


def _why_text(exc: Exception) -> str:
    """An OS or decoding error in a few words."""
    if isinstance(exc, UnicodeDecodeError):
        return "not UTF-8 text"
    return str(getattr(exc, "strerror", None) or exc)[:160]


def _why(exc: Exception) -> str:
    """The reason a file is skipped, in one line."""
    if isinstance(exc, InputError):
        return exc.problem
    kind = type(exc).__name__
    if kind == "error":   # zlib.error, struct.error, ...: say whose
        kind = f"{type(exc).__module__}.{kind}"
    return f"not a readable photomodel file ({kind}: {str(exc)[:200]})"
