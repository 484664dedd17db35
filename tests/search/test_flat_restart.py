"""When level 0 is refined again from the pose laid flat on the table (``flat_restart_deg``).

The restart itself is tested on a wrinkled scene in ``tests/locate/test_locate_strain.py``;
here, that it stays off (no evaluation at all) where it does not apply.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from photomodel.search import NormalEquationsFitness, PyramidConfig, SearchResult, SearchSpace
from photomodel.search._pyramid import _flat_restart
from photomodel.sim import hand_stereo_rig

FACING = hand_stereo_rig().R_cam1_facing
SPACE = SearchSpace.from_ranges(R_cam1_plane=FACING)


class _Untouchable:
    """A fitness with normal equations that fails the test when anything evaluates it."""

    def _fail(self, *args: object) -> np.ndarray:
        raise AssertionError("the restart evaluated the fitness")

    __call__ = evaluate_transforms = last_offsets = normal_equations = _fail


def _result(tilt_deg: float, strain: np.ndarray | None) -> SearchResult:
    R = FACING @ Rotation.from_rotvec([np.radians(tilt_deg), 0.0, 0.0]).as_matrix()
    q = Rotation.from_matrix(R).as_quat()   # (x, y, z, w), w > 0 here
    x = np.concatenate([[10.0, -5.0, 690.0], q[:3]])
    return SearchResult(x, 0.6, 10, 3, "gauss-newton: converged", np.zeros(1), np.zeros(1),
                        strain=strain)


@pytest.mark.parametrize(("tilt_deg", "strain"), [
    (1.5, np.array([-0.02, -0.02, 0.0])),     # shrunk, but nearly flat
    (4.0, np.array([0.002, -0.004, 0.001])),  # tilted, but not shrunk (a tilted table)
    (4.0, None),                              # no strain fitted
])
def test_no_restart_where_it_does_not_apply(tilt_deg: float, strain: np.ndarray | None) -> None:
    assert isinstance(_Untouchable(), NormalEquationsFitness)
    found, used = _flat_restart(_Untouchable(), _result(tilt_deg, strain), SPACE,
                                PyramidConfig(), FACING)
    assert found is None and used == 0


def test_the_restart_needs_a_fitness_with_normal_equations() -> None:
    found, used = _flat_restart(lambda poses: np.zeros(len(poses)),
                                _result(4.0, np.array([-0.02, -0.02, 0.0])), SPACE,
                                PyramidConfig(), FACING)
    assert found is None and used == 0
