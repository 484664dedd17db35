"""Simulator: the paper's cell as a digital twin, writing real-format data with ground truth.

Garments (the catalogue of the paper's 12, a simulated catalogue of up to 100,000 random
articles with look-alike pairs, or a user's own), the model station, the hand stereo rig and
its place in the cell (mount on the PA10, table, photographing pose: :func:`default_hand_eye`,
:func:`table_in_base`, :func:`photo_configuration`), named nuisances (:data:`CONDITIONS`), an
exact renderer for flat items and a mesh renderer for wrinkled cloth, :func:`write_dataset`
(what ``photomodel simulate`` runs), tables of piled garments (:func:`random_table`,
:class:`TableLayout`, ``simulate --table``) and stereo sequences with per-frame truth for trackers
(:func:`write_sequences`, ``simulate --sequences``), and printed labels on garments
(:func:`labelled_garment`, ``simulate --labels``).

Frames follow docs/contracts.md: a texture (and garment) frame has x along the texture's
columns, y along its rows and z into the plane; ``T_a_b`` maps frame b to frame a; lengths in
mm.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
