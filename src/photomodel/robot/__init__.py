"""Robot side of the cell: the PA10-7C's kinematics, hand-eye, pick-and-place plans, animation.

Imports neither ``photomodel.sim`` nor ``photomodel.locate``: the simulated cell and ``pick``
(locate, then plan) live in :mod:`photomodel.cell`, above both.

Frames (docs/contracts.md): ``base`` (the arm's, z up), ``hand`` (tool flange), ``tcp`` (gripper),
``cam1``, ``model``; ``T_a_b`` maps b to a; mm and radians inside, ``_deg`` at the edge.
``T_base_model = T_base_hand(q) @ T_hand_cam1 @ T_cam1_model``.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach_stub(__name__, __file__)
