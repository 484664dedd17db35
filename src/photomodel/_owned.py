"""Caches kept per object (a model, its samples) for as long as that object lives."""

from __future__ import annotations

import weakref
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")

__all__ = ["owned"]


def owned(store: dict[int, T], owner: object, make: Callable[[], T]) -> T:
    """``store``'s entry for ``owner``, made by ``make()`` at the first call and dropped when
    ``owner`` is collected (keyed by ``id(owner)``, which Python reuses after that)."""
    key = id(owner)
    if key not in store:
        store[key] = make()
        weakref.finalize(owner, store.pop, key, None)
    return store[key]
