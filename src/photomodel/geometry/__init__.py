"""Rigid transforms and pose parametrisations (``T_a_b`` maps frame b to frame a)."""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
