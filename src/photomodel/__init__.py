"""photomodel: photo-model based garment recognition and stereo pose search.

The public API lives in the domain subpackages (``photomodel.camera``, ``photomodel.model``,
``photomodel.fitness``, ``photomodel.search``, ``photomodel.locate``, ``photomodel.sim``);
this top-level module only carries the version and the error types.
"""

from photomodel.errors import InputError, PhotomodelError

__all__ = ["InputError", "PhotomodelError", "__version__"]
__version__ = "0.1.0"
