"""Photo-models: generation from a photo (paper sec. 2.2), the model file, the preview."""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
