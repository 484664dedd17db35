# The subpackage's public names (lazy_loader.attach_stub reads this file; type
# checkers read it as the package's stub). One list: add a name here only.

from ._cell import (
    CellConfig,
    CellReport,
    CellSetup,
    CycleOutcome,
    make_cell,
    run_cell,
    run_cycle,
    simulated_hand_eye,
)
from ._clear import (
    ClearConfig,
    ClearLook,
    ClearReport,
    box_layouts,
    clear_table,
    run_clear,
)
from ._clear_animate import (
    animate_clear,
)
from ._pick import (
    PickResult,
    grasp_point_from_photo_px,
    pick,
    write_json_atomic,
)
from ._servo import (
    AIM_MODES,
    ServoOutcome,
    ServoReport,
    ServoSettings,
    ServoTick,
    run_servo_cell,
    run_servo_order,
)
from ._servo_animate import (
    animate_servo,
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
