"""Fuzzing the model loader: model archives with changed metadata, arrays or bytes are read
as a model that the default method can sample and the overlay can project, or refused with
InputError, within a bounded address space."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fuzz_helpers import Tally, bounded_call, fuzz_settings, mutated_bytes, mutated_model
from fuzz_stderr import stderr_of_run
from hypothesis import given
from hypothesis import strategies as st

from photomodel.fitness._samples import SampleSpacing, model_samples
from photomodel.model import load_model
from photomodel.sim import hand_stereo_rig


@pytest.mark.parametrize("profile", ["short", pytest.param("long", marks=pytest.mark.slow)])
def test_fuzzed_models_load_or_raise_input_error(profile: str, tallies, model_seed,
                                                 tmp_path: Path) -> None:
    tally = tallies[profile].setdefault("model", Tally())
    data_seed, arrays, meta = model_seed
    rig = hand_stereo_rig()
    pose = np.eye(4)
    pose[2, 3] = 700.0

    @fuzz_settings("model", long=profile == "long")
    @given(data=st.data())
    def run(data: st.DataObject) -> None:
        if data.draw(st.integers(0, 2), label="byte level only") == 2:
            blob = data.draw(mutated_bytes(data_seed, header=256), label="bytes")
        else:
            blob = data.draw(mutated_model(arrays, meta), label="archive")
        path = tmp_path / "fuzzed.model"
        path.write_bytes(blob)
        model = bounded_call(tally, load_model, path)
        if model is not None:  # what was accepted can be used
            samples = model_samples(model, SampleSpacing())
            assert len(samples.p_in) and len(samples.p_out)
            uv1, uv2 = rig.project_poses(pose, model.outline_mm)
            assert np.isfinite(uv1).all() and np.isfinite(uv2).all()
            assert all(np.isfinite(model.size_mm)) and model.area_mm2 > 0

    with stderr_of_run() as written:
        run()
    assert written == [""], written
    assert tally.other_exceptions == 0
    assert tally.accepted and tally.input_errors
