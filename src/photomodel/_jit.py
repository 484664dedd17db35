"""The one ``njit`` of the package's numba kernels, and where their compiled code is cached.

The cache directory is chosen once, when this module is imported (:data:`CACHE`), first of:

1. ``NUMBA_CACHE_DIR`` (numba's ``config.CACHE_DIR``) when it is set and writable;
2. numba's default, the ``__pycache__`` folder beside each kernel's source, when the
   package's own ``__pycache__`` is writable;
3. the user cache directory ``$XDG_CACHE_HOME/photomodel/numba`` (by default
   ``~/.cache/photomodel/numba``) when writable;
4. none: the kernels compile in every process, after one :class:`JitCacheWarning`.

A cache that cannot be read or written later never stops a kernel: the kernel compiles
(and is not saved, after one warning).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import warnings
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numba
from numba.core import caching

try:
    import fcntl
except ImportError:    # not on POSIX
    fcntl = None  # type: ignore[assignment]

__all__ = ["CACHE", "CacheChoice", "JitCacheWarning", "choose_cache", "njit",
           "user_cache_dir"]


class JitCacheWarning(RuntimeWarning):
    """The compiled kernels cannot be cached (or one could not be saved)."""


@dataclass(frozen=True)
class CacheChoice:
    """Where the compiled kernels are cached.

    Attributes
    ----------
    kind : str
        ``"NUMBA_CACHE_DIR"``, ``"in-tree"`` (each source's ``__pycache__``), ``"user"`` or
        ``"none"`` (not cached).
    root : Path or None
        The cache directory for ``"NUMBA_CACHE_DIR"`` and ``"user"`` (one subfolder per
        source folder, as numba lays out ``NUMBA_CACHE_DIR``); None otherwise.
    tried : tuple of Path
        The directories tried, in order.
    """

    kind: str
    root: Path | None
    tried: tuple[Path, ...]

    @property
    def enabled(self) -> bool:
        """Whether the kernels are cached."""
        return self.kind != "none"

    def describe(self) -> str:
        """One line for people: where the kernels are cached."""
        if self.kind == "in-tree":
            return "the __pycache__ folders beside the sources"
        if self.root is not None:
            return str(self.root)
        return "nowhere (tried " + ", ".join(str(p) for p in self.tried) + ")"


def _writable(path: Path) -> bool:
    """Whether a file can be created in folder ``path`` (created if missing)."""
    try:
        os.makedirs(path, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
    except OSError:
        return False
    return True


def user_cache_dir(environ: Mapping[str, str]) -> Path | None:
    """``$XDG_CACHE_HOME/photomodel/numba``, else ``~/.cache/photomodel/numba`` (``HOME``
    from ``environ``); None when neither is known."""
    xdg = environ.get("XDG_CACHE_HOME", "")
    if os.path.isabs(xdg):
        return Path(xdg) / "photomodel" / "numba"
    home = environ.get("HOME", "")
    if not home:
        try:
            home = str(Path.home())
        except (RuntimeError, KeyError):
            return None
    return Path(home) / ".cache" / "photomodel" / "numba"


def choose_cache(numba_cache_dir: str, package_dir: Path, user_dir: Path | None,
                 writable: Callable[[Path], bool] = _writable) -> CacheChoice:
    """The cache of the kernels: ``numba_cache_dir`` (``NUMBA_CACHE_DIR``, "" when unset),
    else the ``__pycache__`` of ``package_dir``, else ``user_dir``, the first that
    ``writable`` accepts; ``kind="none"`` when none does."""
    tried: list[Path] = []
    if numba_cache_dir:
        root = Path(numba_cache_dir).expanduser()
        tried.append(root)
        if writable(root):
            return CacheChoice("NUMBA_CACHE_DIR", root.resolve(), tuple(tried))
    in_tree = package_dir / "__pycache__"
    tried.append(in_tree)
    if writable(in_tree):
        return CacheChoice("in-tree", None, tuple(tried))
    if user_dir is not None:
        tried.append(user_dir)
        if writable(user_dir):
            return CacheChoice("user", user_dir.resolve(), tuple(tried))
    return CacheChoice("none", None, tuple(tried))


CACHE = choose_cache(numba.config.CACHE_DIR or "", Path(__file__).resolve().parent,
                     user_cache_dir(os.environ))
"""Where this process caches the kernels (chosen at import)."""

if not CACHE.enabled:
    warnings.warn("photomodel: no writable cache directory for the compiled numba kernels "
                  f"(tried {', '.join(str(p) for p in CACHE.tried)}); they compile again in "
                  "every process. Set NUMBA_CACHE_DIR to a writable directory.",
                  JitCacheWarning, stacklevel=1)


class _Locator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
    """The cache folder of a kernel: its source's ``__pycache__`` or a subfolder of
    :data:`CACHE`'s root."""

    def __init__(self, py_func: Callable[..., Any], py_file: str) -> None:
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        if CACHE.root is None:
            self._cache_path = os.path.join(os.path.dirname(py_file), "__pycache__")
        else:
            self._cache_path = os.path.join(str(CACHE.root),
                                            self.get_suitable_cache_subpath(py_file))

    def get_cache_path(self) -> str:
        return self._cache_path

    @classmethod
    def from_function(cls, py_func: Callable[..., Any], py_file: str) -> _Locator | None:
        if not os.path.exists(py_file):
            return None
        return cls(py_func, py_file)


class _CacheImpl(caching.CompileResultCacheImpl):
    _locator_classes = [_Locator]


_unsaved_warned = False

_LOCK_NAME = ".photomodel-cache.lock"


@contextlib.contextmanager
def _locked(folder: str) -> Iterator[None]:
    """Hold an exclusive lock on the cache ``folder`` (none where ``fcntl`` is missing):
    numba reads a function's index, adds an entry and writes it back, and two processes
    saving at once could lose one entry or number two data files alike."""
    if fcntl is None:
        yield
        return
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, _LOCK_NAME), "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


class _FunctionCache(caching.FunctionCache):
    """numba's cache of compile results, in :data:`CACHE`; saves locked (:func:`_locked`), a
    file that cannot be read a miss, one that cannot be written a warning (once a
    process)."""

    _impl_class = _CacheImpl

    def __init__(self, py_func: Callable[..., Any], options: str = "") -> None:
        super().__init__(py_func)
        self._options = options

    def _index_key(self, sig: Any, codegen: Any) -> Any:
        # numba's key holds the bytecode, not the compile options: a kernel compiled
        # before its options changed (nogil, fastmath) must not be loaded after
        return (*super()._index_key(sig, codegen), self._options)

    def load_overload(self, sig: Any, target_context: Any) -> Any:
        try:
            return super().load_overload(sig, target_context)
        except OSError:
            return None

    def save_overload(self, sig: Any, data: Any) -> None:
        global _unsaved_warned
        try:
            with _locked(self.cache_path):
                super().save_overload(sig, data)
        except OSError as exc:
            if not _unsaved_warned:
                _unsaved_warned = True
                warnings.warn(f"photomodel: a compiled kernel could not be cached in "
                              f"{self.cache_path}: {exc}", JitCacheWarning, stacklevel=2)


def njit(func: Callable[..., Any] | None = None, **options: Any) -> Any:
    """``numba.njit`` with the package's cache (:data:`CACHE`): ``@njit`` or
    ``@njit(parallel=True, fastmath=True, ...)``, numba's options except ``cache``;
    ``nogil=True`` unless told otherwise (kernels run in several threads at once)."""
    options.pop("cache", None)
    options.setdefault("nogil", True)   # a service runs searches in threads

    def decorate(f: Callable[..., Any]) -> Any:
        dispatcher = numba.njit(**options)(f)
        if CACHE.enabled:
            try:
                dispatcher._cache = _FunctionCache(f, repr(sorted(options.items())))
            except (OSError, RuntimeError):
                pass    # no cache for this one (a source numba cannot locate): it compiles
        return dispatcher

    return decorate(func) if func is not None else decorate
