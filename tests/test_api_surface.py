"""The public surface of ``import photomodel as pm`` and of every subpackage is pinned: names
and signatures (``tests/api_surface.json``, ``tests/api_surface_subpackages.json``).

A change to a public name or signature fails here until the files are updated on purpose:
``PHOTOMODEL_UPDATE_API_SURFACE=1 python -m pytest tests/test_api_surface.py``.
"""

from __future__ import annotations

import importlib
import inspect
import json
import os
import pkgutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import photomodel as pm

SURFACE_FILE = Path(__file__).with_name("api_surface.json")
SUBPACKAGES_FILE = Path(__file__).with_name("api_surface_subpackages.json")
SUBPACKAGES = sorted(m.name for m in pkgutil.iter_modules(pm.__path__)
                     if m.ispkg and m.name != "cli")


def _signature(obj: Any) -> str:
    try:
        return str(inspect.signature(obj))
    except (TypeError, ValueError):
        return "<no signature>"


def public_surface(package: Any = pm) -> dict[str, Any]:
    """Each public name of ``package``: its kind and signature; for a class also its
    public methods' and properties' signatures."""
    out: dict[str, Any] = {}
    for name in sorted(package.__all__):
        obj = getattr(package, name)
        if inspect.isclass(obj):
            members = {}
            for attr, value in sorted(vars(obj).items()):
                if attr.startswith("_") and attr not in ("__init__", "__call__"):
                    continue
                if isinstance(value, property):
                    members[attr] = "property"
                elif inspect.isfunction(value):
                    members[attr] = _signature(value)
                elif isinstance(value, classmethod | staticmethod):
                    members[attr] = _signature(value.__func__)
            out[name] = {"kind": "class", "signature": _signature(obj), "members": members}
        elif callable(obj):
            out[name] = {"kind": "function", "signature": _signature(obj)}
        else:
            out[name] = {"kind": type(obj).__name__}
    return out


def test_the_public_surface_matches_the_pinned_file() -> None:
    surface = public_surface()
    if os.environ.get("PHOTOMODEL_UPDATE_API_SURFACE"):
        SURFACE_FILE.write_text(json.dumps(surface, indent=1, sort_keys=True) + "\n")
    pinned = json.loads(SURFACE_FILE.read_text())
    assert sorted(surface) == sorted(pinned), "public names changed"
    for name in pinned:
        assert surface[name] == pinned[name], f"{name} changed"


def test_every_subpackages_surface_matches_the_pinned_file() -> None:
    surface = {f"photomodel.{sub}": public_surface(importlib.import_module(f"photomodel.{sub}"))
               for sub in SUBPACKAGES}
    if os.environ.get("PHOTOMODEL_UPDATE_API_SURFACE"):
        SUBPACKAGES_FILE.write_text(json.dumps(surface, indent=1, sort_keys=True) + "\n")
    pinned = json.loads(SUBPACKAGES_FILE.read_text())
    assert sorted(surface) == sorted(pinned), "subpackages changed"
    for package, names in pinned.items():
        assert sorted(surface[package]) == sorted(names), f"{package}: public names changed"
        for name in names:
            assert surface[package][name] == names[name], f"{package}.{name} changed"


def test_every_public_name_resolves_and_the_dir_lists_only_them() -> None:
    for name in pm.__all__:
        assert getattr(pm, name) is not None
    assert sorted(dir(pm)) == sorted(pm.__all__)
    for sub in SUBPACKAGES:
        package = importlib.import_module(f"photomodel.{sub}")
        assert sorted(dir(package)) == sorted(package.__all__), sub


def test_importing_photomodel_loads_no_heavy_module() -> None:
    """``import photomodel`` is cheap: names load on first use."""
    code = ("import sys, photomodel; heavy = [m for m in ('numpy', 'numba', 'cv2', 'scipy', "
            "'matplotlib', 'cma') if m in sys.modules]; print(','.join(heavy))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert done.stdout.strip() == ""
