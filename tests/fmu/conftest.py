"""Fixtures of the FMU tests."""
from __future__ import annotations

import pytest
from support.fmu_loop import Loop


@pytest.fixture
def loops():
    """Loops created by a test; freed even when it fails (unfreed instances crash the host at exit)."""
    made: list[Loop] = []
    yield made
    for loop in made:
        loop.free()
