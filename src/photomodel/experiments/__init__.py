"""The accuracy experiment: many recognitions on simulated (or recorded) scenes, their records,
the paper's statistics (Table 1) and figures, run locally or on a Dask cluster, resumable.

The figures (``photomodel.experiments._report``, matplotlib) load only when a report is written.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
