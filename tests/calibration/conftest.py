"""Shared fixtures of the calibration tests: small simulated logs and synthetic logs."""

from __future__ import annotations

import pandas as pd
import pytest


@pytest.fixture(scope="session")
def soak_small() -> tuple[pd.DataFrame, pd.DataFrame, dict]:
    """Seven soak cold starts (Table 3), 1 h each at 0.5 Hz: the simulator's plant."""
    from rinscal.thermal.protocols import simulate_protocol

    return simulate_protocol("soak", hours=1.0, rate_hz=0.5, seed=11)


@pytest.fixture(scope="session")
def repeat_small() -> tuple[pd.DataFrame, pd.DataFrame, dict]:
    """The repetition-priming cold start at 25 °C, 2 h at 0.5 Hz."""
    from rinscal.thermal.protocols import simulate_protocol

    return simulate_protocol("repeat", hours=2.0, rate_hz=0.5, seed=12)
