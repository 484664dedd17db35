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

__getattr__, __dir__, _ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "_cell": [
            "CellConfig",
            "CellReport",
            "CellSetup",
            "CycleOutcome",
            "make_cell",
            "run_cell",
            "run_cycle",
            "simulated_hand_eye",
        ],
        "_clear": ["ClearConfig", "ClearLook", "ClearReport", "box_layouts", "clear_table",
                   "run_clear"],
        "_clear_animate": ["animate_clear"],
        "_pick": ["PickResult", "grasp_point_from_photo_px", "pick", "write_json_atomic"],
        "_servo": [
            "AIM_MODES",
            "ServoOutcome",
            "ServoReport",
            "ServoSettings",
            "ServoTick",
            "run_servo_cell",
            "run_servo_order",
        ],
        "_servo_animate": ["animate_servo"],
    },
)

__all__ = [
    "AIM_MODES",
    "CellConfig",
    "CellReport",
    "CellSetup",
    "ClearConfig",
    "ClearLook",
    "ClearReport",
    "CycleOutcome",
    "PickResult",
    "ServoOutcome",
    "ServoReport",
    "ServoSettings",
    "ServoTick",
    "animate_clear",
    "animate_servo",
    "box_layouts",
    "clear_table",
    "grasp_point_from_photo_px",
    "make_cell",
    "pick",
    "run_cell",
    "run_clear",
    "run_cycle",
    "run_servo_cell",
    "run_servo_order",
    "simulated_hand_eye",
    "write_json_atomic",
]
