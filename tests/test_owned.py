"""Caches kept per object: made once, dropped with their owner."""

from __future__ import annotations

import gc

from photomodel._owned import owned


class _Owner:
    pass


def test_an_entry_is_made_once_and_dropped_with_its_owner() -> None:
    store: dict[int, list[int]] = {}
    owner = _Owner()
    made = owned(store, owner, list)
    made.append(1)
    assert owned(store, owner, list) is made and len(store) == 1
    del owner
    gc.collect()
    assert store == {}
