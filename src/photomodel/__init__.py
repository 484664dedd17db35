"""photomodel: photo-model based garment recognition and stereo 6-DoF pose search.

The public API, kept small (``tests/api_surface.json`` pins it)::

    import photomodel as pm
    rig = pm.load_stereo("stereo.yaml")
    model = pm.load_model("shirt.model")
    locate = pm.Locator(model, rig)
    result = locate(pm.read_image("right.png"), pm.read_image("left.png"), rng=0)

Names are imported on first use (SPEC 1 lazy loading), so ``import photomodel`` costs little;
the domain subpackages (``photomodel.camera``, ``.model``, ``.fitness``, ``.search``,
``.locate``, ``.identify``, ``.sim``, ...) hold the rest.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from photomodel.errors import InputError, PhotomodelError

__version__ = "0.1.0"

_LAZY: dict[str, str] = {
    "IdentifyConfig": "photomodel.identify",
    "IdentifyResult": "photomodel.identify",
    "Identifier": "photomodel.identify",
    "LocateResult": "photomodel.locate",
    "Locator": "photomodel.locate",
    "ModelLibrary": "photomodel.library",
    "PaperMethod": "photomodel.locate",
    "PhotoModel": "photomodel.model",
    "PinholeCamera": "photomodel.camera",
    "SearchSpace": "photomodel.search",
    "StereoRig": "photomodel.camera",
    "TrackResult": "photomodel.track",
    "Tracker": "photomodel.track",
    "TrackerConfig": "photomodel.track",
    "build_model": "photomodel.model",
    "load_camera": "photomodel.camera",
    "load_model": "photomodel.model",
    "load_stereo": "photomodel.camera",
    "read_image": "photomodel.image",
    "save_model": "photomodel.model",
}
_RENAMED = {"read_image": "read_color_image"}

__all__ = ["InputError", "PhotomodelError", "__version__", *sorted(_LAZY)]


def __dir__() -> list[str]:
    """The public names only (``dir(pm)``, tab completion)."""
    return list(__all__)


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'photomodel' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), _RENAMED.get(name, name))
    globals()[name] = value
    return value


if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs only
    # ruff: noqa: F401
    from photomodel.camera import PinholeCamera, StereoRig, load_camera, load_stereo
    from photomodel.identify import Identifier, IdentifyConfig, IdentifyResult
    from photomodel.image import read_color_image as read_image
    from photomodel.library import ModelLibrary
    from photomodel.locate import LocateResult, Locator, PaperMethod
    from photomodel.model import PhotoModel, build_model, load_model, save_model
    from photomodel.search import SearchSpace
    from photomodel.track import Tracker, TrackerConfig, TrackResult
