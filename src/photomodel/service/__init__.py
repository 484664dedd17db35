"""The cell service: a resident photomodel that a cell controller calls over HTTP, or a PLC
over OPC UA (``photomodel serve``; contract in docs/contracts.md)."""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
