"""The arms' data files (link lengths, joint limits), read without numpy: the command line
lists the link sets while it builds its parser."""

from __future__ import annotations

import json
from importlib import resources
from typing import Any

from photomodel.errors import InputError

__all__ = ["ARM_FILES", "available_link_sets"]

ARM_FILES: dict[str, str] = {"pa10-7c": "pa10_7c.json"}


def _arm_file(arm: str) -> dict[str, Any]:
    if arm not in ARM_FILES:
        raise InputError("--arm", f"unknown arm {arm!r}; known: {', '.join(sorted(ARM_FILES))}")
    text = resources.files("photomodel.robot").joinpath("data", ARM_FILES[arm]).read_text()
    data: dict[str, Any] = json.loads(text)
    return data


def available_link_sets(arm: str = "pa10-7c") -> tuple[str, ...]:
    """Names of the link-length sets the arm's data file holds."""
    return tuple(_arm_file(arm)["link_sets"])
