"""The cell end to end: the simulated cell's orders and ``pick`` from a stereo pair and joints.

:func:`run_cell` (what ``photomodel cell`` runs) photographs each order's garment at the model
station, photographs the table from the PA10's hand, locates the garment and plans its pick,
against the simulator's truth; :func:`run_servo_cell` (``cell --servo``) picks garments from a
moving conveyor, open loop and servoed by the tracker at camera rate; :func:`run_clear`
(``cell --tables``) clears piles of garments into one box per model (:func:`animate_clear`
draws a table's looks); :func:`pick` (what ``photomodel pick`` runs) locates a model in a real
stereo pair taken at known joints and plans its pick and place.

Sits above ``locate``, ``sim`` and ``robot`` and uses their public names; none of them imports
it. Frames follow docs/contracts.md: ``T_a_b`` maps b to a, mm and radians inside;
``T_base_model = T_base_hand(q) @ T_hand_cam1 @ T_cam1_model``.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
