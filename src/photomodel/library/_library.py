"""A model library: a directory of photo-model files with an index.

Layout::

    DIR/<name>.npz     one self-contained photo-model each (:func:`photomodel.model.save_model`)
    DIR/index.json     {"format": "photomodel-library", "version": 1,
                        "models": {"<name>": {"file", "size_mm", "area_mm2", "colours",
                                              "n_in", "n_out", "created_utc", "added_utc",
                                              "file_bytes", "file_mtime_ns"}}}

The model files are the truth; the index caches what listing needs (name, size, main colours,
dates) so that ``models list`` does not open every file. :meth:`ModelLibrary.scan` reconciles
the two: an indexed file that is unchanged (same byte count and modification time) is taken
from the index, any other ``.npz`` file is opened, and a file that is not a readable
photo-model (corrupt, foreign, of a newer format), a model whose name another file already
has, or an index entry whose file is gone is *skipped* with a :class:`Skipped` note naming it;
nothing else in the directory is looked at. The index is written atomically (temporary file,
then rename) by :meth:`ModelLibrary.add`, :meth:`ModelLibrary.remove` and
:meth:`ModelLibrary.reindex`, never by a read.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from photomodel.errors import InputError
from photomodel.model import PhotoModel, load_model, save_model

__all__ = [
    "INDEX_NAME",
    "LIBRARY_FORMAT_VERSION",
    "LibraryEntry",
    "LibraryScan",
    "ModelLibrary",
    "Skipped",
    "check_model_name",
    "main_colours",
]

INDEX_NAME = "index.json"
LIBRARY_FORMAT_VERSION = 1
_FORMAT = "photomodel-library"
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
        When it entered the library (ISO 8601).
    file_bytes, file_mtime_ns : int
        Size and modification time of the file when it was indexed.
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

    def to_json_dict(self) -> dict[str, Any]:
        """The entry as stored in ``index.json`` (without its name, which is the key)."""
        d = asdict(self)
        d.pop("name")
        d["size_mm"] = list(self.size_mm)
        d["colours"] = [list(c) for c in self.colours]
        return d

    @classmethod
    def from_json_dict(cls, name: str, d: dict[str, Any]) -> LibraryEntry:
        """Inverse of :meth:`to_json_dict`; ValueError/KeyError/TypeError when malformed."""
        return cls(
            name=str(name), file=str(d["file"]),
            size_mm=(float(d["size_mm"][0]), float(d["size_mm"][1])),
            area_mm2=float(d["area_mm2"]),
            colours=tuple((str(c[0]), float(c[1])) for c in d["colours"]),
            n_in=int(d["n_in"]), n_out=int(d["n_out"]), created_utc=str(d["created_utc"]),
            added_utc=str(d["added_utc"]), file_bytes=int(d["file_bytes"]),
            file_mtime_ns=int(d["file_mtime_ns"]))


@dataclass(frozen=True)
class Skipped:
    """A file (or index entry) of the library that was left out, and why."""

    path: Path
    reason: str

    def __str__(self) -> str:
        return f"{self.path}: skipped: {self.reason}"


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


def check_model_name(name: str) -> str:
    """``name`` if it can be a library file name, else InputError naming it."""
    if (not name or name in (".", "..") or name.startswith(".")
            or any(c in _BAD_NAME_CHARS for c in name)):
        raise InputError("name", f"{name!r} cannot be a model name in a library (no path "
                                 "separators, no leading dot)")
    return name


class ModelLibrary:
    """A directory of photo-models with an index (see the module docstring).

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
            if self.root.exists():
                raise InputError(self.root, "is not a directory")
            if not create:
                raise InputError(self.root, "model library directory not found")
            try:
                self.root.mkdir(parents=True)
            except OSError as exc:
                raise InputError(self.root, f"cannot create it ({exc.strerror})") from None

    @property
    def index_path(self) -> Path:
        """``DIR/index.json``."""
        return self.root / INDEX_NAME

    # --- the index ---------------------------------------------------------------------------

    def _read_index(self) -> tuple[dict[str, LibraryEntry], list[Skipped]]:
        """Entries of ``index.json`` (empty if missing); a damaged index is noted and ignored."""
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
            entries = {}
            for name, d in dict(data.get("models", {})).items():
                entries[str(name)] = LibraryEntry.from_json_dict(name, d)
            return entries, []
        except (OSError, ValueError, KeyError, TypeError, IndexError) as exc:
            return {}, [Skipped(path, f"index ignored, models read from their files ({exc})")]

    def _write_index(self, entries: dict[str, LibraryEntry]) -> None:
        data = {"format": _FORMAT, "version": LIBRARY_FORMAT_VERSION,
                "models": {n: entries[n].to_json_dict() for n in sorted(entries)}}
        tmp = self.root / f".{INDEX_NAME}.tmp-{os.getpid()}"
        try:
            tmp.write_text(json.dumps(data, indent=1) + "\n")
            os.replace(tmp, self.index_path)
        finally:
            tmp.unlink(missing_ok=True)

    # --- reading -----------------------------------------------------------------------------

    def _entry_for(self, path: Path, model: PhotoModel, added_utc: str) -> LibraryEntry:
        st = path.stat()
        return LibraryEntry(
            name=model.name, file=path.name, size_mm=model.size_mm, area_mm2=model.area_mm2,
            colours=main_colours(model), n_in=model.n_in, n_out=model.n_out,
            created_utc=str(model.meta.get("created_utc", "")), added_utc=added_utc,
            file_bytes=int(st.st_size), file_mtime_ns=int(st.st_mtime_ns))

    def scan(self) -> LibraryScan:
        """The usable models and the skipped files (reads only what the index cannot vouch for).

        Returns
        -------
        LibraryScan
        """
        indexed, skipped = self._read_index()
        by_file = {e.file: e for e in indexed.values()}
        entries: dict[str, LibraryEntry] = {}
        for path in sorted(self.root.glob("*.npz")):
            if path.name.startswith(".") or not path.is_file():
                continue
            st = path.stat()
            cached = by_file.get(path.name)
            if (cached is not None and cached.file_bytes == st.st_size
                    and cached.file_mtime_ns == st.st_mtime_ns):
                entry = cached
            else:
                try:
                    model = load_model(path)
                except InputError as exc:
                    skipped.append(Skipped(path, exc.problem))
                    continue
                entry = self._entry_for(path, model,
                                        cached.added_utc if cached is not None else _now())
            if entry.name in entries:
                skipped.append(Skipped(path, f"model name {entry.name!r} is already taken by "
                                             f"{entries[entry.name].file}"))
                continue
            entries[entry.name] = entry
        for e in indexed.values():
            if not (self.root / e.file).is_file():
                skipped.append(Skipped(self.root / e.file,
                                       f"listed in {INDEX_NAME} as {e.name!r} but the file is "
                                       "missing"))
        return LibraryScan(tuple(entries[n] for n in sorted(entries)), tuple(skipped))

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
                models.append(load_model(path))
            except InputError as exc:
                skipped.append(Skipped(path, exc.problem))
        return models, skipped

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
        model = load_model(model_path)
        if name is not None and name != model.name:
            model = PhotoModel(**{**model.__dict__, "name": name})
        check_model_name(model.name)
        scan = self.scan()
        taken = {e.name: e for e in scan.entries}
        if model.name in taken and not replace:
            raise InputError(self.root, f"already holds a model named {model.name!r} "
                                        "(use --replace to replace it)")
        target = self.root / f"{model.name}.npz"
        if model.name not in taken and target.exists():
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
        """Delete model ``name``'s file and its index entry; InputError when there is none."""
        scan = self.scan()
        entries = {e.name: e for e in scan.entries}
        if name not in entries:
            raise InputError(self.root, f"no model named {name!r} in the library")
        gone = entries.pop(name)
        self._write_index(entries)
        (self.root / gone.file).unlink(missing_ok=True)
        return gone

    def reindex(self) -> LibraryScan:
        """Rewrite ``index.json`` from the files (skipped files stay out); returns the scan."""
        scan = self.scan()
        self._write_index({e.name: e for e in scan.entries})
        return scan
