"""Fuzzing the image loader: mutated PNG, BMP and JPEG files are read as a colour image or
refused with InputError, within a bounded address space, and print nothing on stderr."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fuzz_helpers import Tally, bounded_call, fix_png_crcs, fuzz_settings, mutated_bytes
from fuzz_stderr import stderr_of_run
from hypothesis import given
from hypothesis import strategies as st

from photomodel.image import read_color_image


@pytest.mark.parametrize("profile", ["short", pytest.param("long", marks=pytest.mark.slow)])
def test_fuzzed_images_load_or_raise_input_error(profile: str, tallies, image_seeds,
                                                 tmp_path: Path) -> None:
    tally = tallies[profile].setdefault("image", Tally())
    names = sorted(image_seeds)

    @fuzz_settings("image", long=profile == "long")
    @given(data=st.data())
    def run(data: st.DataObject) -> None:
        name = data.draw(st.sampled_from(names), label="seed")
        keep = 8 if name.endswith(".png") else 2
        blob = data.draw(mutated_bytes(image_seeds[name], keep=keep), label="bytes")
        if name.endswith(".png") and data.draw(st.booleans(), label="fix CRCs"):
            blob = fix_png_crcs(blob)
        path = tmp_path / f"fuzzed{Path(name).suffix}"
        path.write_bytes(blob)
        image = bounded_call(tally, read_color_image, path)
        if image is not None:
            assert image.dtype == np.uint8 and image.ndim == 3 and image.shape[2] == 3
            assert image.flags.c_contiguous

    with stderr_of_run() as written:
        run()
    assert written == [""], written
    assert tally.other_exceptions == 0
    assert tally.accepted and tally.input_errors  # both outcomes were reached
