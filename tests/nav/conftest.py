"""Session fixtures: recordings made like the real one (``tests/nav/_realistic.py``), each
simulated once per test session."""

from __future__ import annotations

import pytest

from tests.nav._realistic import Realistic, write_realistic


@pytest.fixture(scope="session")
def realistic_rlg(tmp_path_factory: pytest.TempPathFactory) -> Realistic:
    """Ring-laser counts at 100 Hz, 31 min, a parked vehicle disturbed for 9 min."""
    return write_realistic(tmp_path_factory.mktemp("realistic_rlg"), "ring_laser")


@pytest.fixture(scope="session")
def realistic_rlg_1hz(tmp_path_factory: pytest.TempPathFactory) -> Realistic:
    """The same unit recorded at 1 Hz."""
    return write_realistic(tmp_path_factory.mktemp("realistic_rlg_1hz"), "ring_laser_1hz")


@pytest.fixture(scope="session")
def realistic_fog(tmp_path_factory: pytest.TempPathFactory) -> Realistic:
    """The FOG-like unit (rate output, white rate noise) on the same disturbed start."""
    return write_realistic(tmp_path_factory.mktemp("realistic_fog"), "fog")
