"""Fixtures of the identification tests."""

from __future__ import annotations

import pytest
from identify_helpers import IdentifyData, make_identify_data


@pytest.fixture(scope="session")
def identify_data(tmp_path_factory: pytest.TempPathFactory) -> IdentifyData:
    return make_identify_data(tmp_path_factory.mktemp("identify"))
