"""What the fitnesses derive from a photo-model, kept in an object beside the model.

A :class:`PreparedModel` wraps one :class:`~photomodel.model.PhotoModel` and keeps, for as
long as it lives, the samples of every pyramid level and blur, the scans' kernels and the
screening histograms that the searches build from the model. Every function that takes a
model takes either: a bare ``PhotoModel`` is prepared afresh for that call (nothing is kept
between calls), a ``PreparedModel`` is reused. :class:`photomodel.Locator` and
:class:`photomodel.Identifier` hold one per model.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any, TypeVar

from photomodel.model import PhotoModel

__all__ = ["Kept", "PreparedModel", "as_prepared"]

T = TypeVar("T")


class Kept:
    """Values derived from one object, each made by its ``make()`` at first use and kept.

    Safe to share between threads: two threads asking for a missing key at once may both
    make it, and the first one stored is what both get.
    """

    def __init__(self) -> None:
        self._values: dict[Hashable, Any] = {}
        self._lock = threading.Lock()

    def __contains__(self, key: Hashable) -> bool:
        return key in self._values

    def __len__(self) -> int:
        return len(self._values)

    def get(self, key: Hashable, make: Callable[[], T]) -> T:
        """The value kept under ``key``, made by ``make()`` when there is none."""
        try:
            return self._values[key]  # type: ignore[no-any-return]
        except KeyError:
            pass
        value = make()
        return self._values.setdefault(key, value)  # type: ignore[no-any-return]

    def recent(self, store: Hashable, key: Hashable, make: Callable[[], T], limit: int) -> T:
        """``make()``'s value under ``key`` in the bounded store ``store``: at most ``limit``
        values, the least recently used one dropped first."""
        lru: OrderedDict[Hashable, Any] = self.get(store, OrderedDict)
        with self._lock:
            if key in lru:
                lru.move_to_end(key)
                return lru[key]  # type: ignore[no-any-return]
        value = make()
        with self._lock:
            lru.setdefault(key, value)
            lru.move_to_end(key)
            while len(lru) > limit:
                lru.popitem(last=False)
            return lru[key]  # type: ignore[no-any-return]


class PreparedModel:
    """A photo-model and what the searches derived from it (see the module docstring).

    Parameters
    ----------
    model : PhotoModel
    """

    def __init__(self, model: PhotoModel) -> None:
        if not isinstance(model, PhotoModel):
            raise TypeError(f"model: expected a PhotoModel, got {type(model).__name__}")
        self.model = model
        self.kept = Kept()

    @property
    def name(self) -> str:
        """The model's name."""
        return self.model.name

    def __repr__(self) -> str:
        return f"PreparedModel({self.model.name!r}, {len(self.kept)} kept)"


def as_prepared(model: PhotoModel | PreparedModel) -> PreparedModel:
    """``model`` itself when prepared, else a new :class:`PreparedModel` of it."""
    return model if isinstance(model, PreparedModel) else PreparedModel(model)
