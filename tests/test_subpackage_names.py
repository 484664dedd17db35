"""Every name a subpackage lists in ``__all__`` resolves (the lazy-loader tables and the lists
are written by hand and must agree)."""

from __future__ import annotations

import importlib
import pkgutil

import pytest

import photomodel

SUBPACKAGES = sorted(m.name for m in pkgutil.iter_modules(photomodel.__path__)
                     if m.ispkg)


@pytest.mark.parametrize("name", SUBPACKAGES)
def test_every_listed_name_resolves(name: str) -> None:
    package = importlib.import_module(f"photomodel.{name}")
    listed = getattr(package, "__all__", [])
    assert len(listed) == len(set(listed)), f"photomodel.{name}.__all__ repeats a name"
    missing = [n for n in listed if not hasattr(package, n)]
    assert missing == [], f"photomodel.{name} lists {missing} but does not provide them"
