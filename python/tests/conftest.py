"""Shared fixtures: the repository's scenes."""

import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture
def cbox() -> str:
    """The Mitsuba Cornell box (its $res parameter sets the size)."""
    return str(ROOT / "scenes" / "mitsuba" / "cbox.xml")
