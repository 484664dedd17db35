"""``PreparedModels``: the models of a library prepared on first use, at most N kept (LRU).

A catalogue of thousands of models cannot be prepared at start-up (about 0.05 s and 20 MB each
with 640 x 480 cameras, most of it the scans' transformed kernels): a model is loaded from its
file and prepared for the rig (a :class:`~photomodel.Locator`) the first time a search needs
it, and the least recently used one is dropped when more than ``capacity`` are held.
Thread-safe: two threads asking for the same model prepare it once.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass

from photomodel.camera import StereoRig
from photomodel.locate import Locator
from photomodel.model import PhotoModel
from photomodel.search import SearchSpace

__all__ = ["CacheStats", "PreparedModels"]


@dataclass(frozen=True)
class CacheStats:
    """Counts of a :class:`PreparedModels`: held now, capacity, hits, models prepared on a
    lookup (misses; not those handed in by ``put``) and models evicted."""

    prepared: int
    capacity: int
    hits: int
    misses: int
    evicted: int


class PreparedModels:
    """A bounded, least-recently-used cache of :class:`~photomodel.Locator` by model name.

    Parameters
    ----------
    load : callable(name) -> PhotoModel
        Reads a model (e.g. from the library's file); raises for an unknown name.
    rig : StereoRig
    capacity : int
        Most models kept prepared (at least 1).
    space : SearchSpace, optional
    min_score : float, optional
        Threshold of every Locator.
    prepare : callable(Locator) -> None, optional
        Extra work on a new Locator (the service runs one search on a blank pair).
    """

    def __init__(self, load: Callable[[str], PhotoModel], rig: StereoRig, capacity: int, *,
                 space: SearchSpace | None = None, min_score: float | None = None,
                 prepare: Callable[[Locator], None] | None = None) -> None:
        if capacity < 1:
            raise ValueError(f"capacity: expected at least 1 prepared model, got {capacity}")
        self._load = load
        self.rig = rig
        self.capacity = int(capacity)
        self.space = space
        self.min_score = min_score
        self._prepare = prepare
        self._held: OrderedDict[str, Locator] = OrderedDict()
        self._lock = threading.Lock()
        self._making: dict[str, threading.Lock] = {}
        self._generation: dict[str, int] = {}   # bumped by drop(): a stale load is not kept
        self._hits = self._misses = self._evicted = 0

    def _held_one(self, name: str) -> Locator | None:
        """The held Locator of ``name``, marked recently used (call holding ``_lock``)."""
        locator = self._held.get(name)
        if locator is not None:
            self._held.move_to_end(name)
            self._hits += 1
        return locator

    def get(self, name: str, load: Callable[[str], PhotoModel] | None = None) -> Locator:
        """The prepared Locator of model ``name`` (loaded with ``load``, default the
        cache's, and prepared when not held)."""
        with self._lock:
            locator = self._held_one(name)
            if locator is not None:
                return locator
            making = self._making.setdefault(name, threading.Lock())
        try:
            with making:     # one thread prepares a model; the others wait for it
                with self._lock:
                    locator = self._held_one(name)
                    if locator is not None:
                        return locator
                    generation = self._generation.get(name, 0)
                locator = self.make((load or self._load)(name))
                with self._lock:
                    self._misses += 1
                    if self._generation.get(name, 0) == generation:   # not dropped meanwhile
                        self._hold(locator)
        finally:
            with self._lock:
                self._making.pop(name, None)
        return locator

    def make(self, model: PhotoModel) -> Locator:
        """A new, prepared Locator of ``model`` for the rig (not held)."""
        locator = Locator(model, self.rig, self.space, min_score=self.min_score)
        if self._prepare is not None:
            self._prepare(locator)
        return locator

    def put(self, locator: Locator) -> None:
        """Hold ``locator`` (under its model's name, replacing an older one), dropping the
        least recently used beyond the capacity."""
        with self._lock:
            self._hold(locator)

    def _hold(self, locator: Locator) -> None:
        """:meth:`put` holding ``_lock``."""
        name = locator.model.name
        self._held[name] = locator
        self._held.move_to_end(name)
        while len(self._held) > self.capacity:
            self._held.popitem(last=False)
            self._evicted += 1

    def peek(self, name: str) -> Locator | None:
        """The held Locator of ``name`` without loading or reordering, None when not held."""
        with self._lock:
            return self._held.get(name)

    def drop(self, name: str) -> None:
        """Forget model ``name`` (removed or replaced in the library); a preparation of it
        under way is not kept."""
        with self._lock:
            self._held.pop(name, None)
            self._generation[name] = self._generation.get(name, 0) + 1

    def stats(self) -> CacheStats:
        """The counts (see :class:`CacheStats`)."""
        with self._lock:
            return CacheStats(len(self._held), self.capacity, self._hits, self._misses,
                              self._evicted)

    def __len__(self) -> int:
        with self._lock:
            return len(self._held)

    def __contains__(self, name: object) -> bool:
        with self._lock:
            return name in self._held
