"""Synthetic calibration logs for the calibration tests."""

from __future__ import annotations

import numpy as np
import pandas as pd

from rinscal.schema import CHANNELS


def synthetic_log(
    rng: np.random.Generator,
    runs: int = 3,
    n: int = 400,
    dt: float = 1.0,
    gradient: bool = True,
) -> pd.DataFrame:
    """A canonical log with smooth random temperatures (per channel) and zero outputs."""
    frames = []
    for k in range(runs):
        t = (np.arange(n) + 1.0) * dt
        base = 5.0 + 30.0 * rng.random() + 10.0 * (1 - np.exp(-t / (n * dt / 3)))
        cols: dict[str, object] = {"time_s": t, "run": f"run{k}"}
        for j, c in enumerate(CHANNELS):
            cols[c] = np.zeros(n)
            cols[f"temp_{c}"] = base + 0.3 * j + 0.5 * np.sin(t / (50 + 7 * j))
        if gradient:
            cols["temp_out"] = base - 1.0 - 0.8 * np.exp(-t / (n * dt / 5))
        cols["chamber_temp"] = np.full(n, 7.0 * k)
        frames.append(pd.DataFrame(cols))
    return pd.concat(frames, ignore_index=True)


def linear_model(k_temp: float = 1e-6, k_rate: float = 1e-5):  # type: ignore[no-untyped-def]
    """A model file with known coefficients: ``f = k_temp·T + k_rate·Ṫ`` per channel
    [T in °C, Ṫ in °C/min, f in SI: unit_to_si 1], static reference 0, and every input
    inside its training range (−100-200 °C, ±1000 °C/min)."""
    from rinscal.calibration.modelfile import ChannelModel, ThermalModelFile

    params = {"method": "regression", "orders": [1, 1], "center": [0.0, 0.0],
              "scale": [1.0, 1.0], "intercept": 0.0, "coef": [[k_temp], [k_rate]]}  # fmt: skip
    cm = ChannelModel(
        params=params,
        train_range=np.array([[-100.0, 200.0], [-1e3, 1e3]]),
        unit="SI",
        unit_to_si=1.0,
        static_reference=0.0,
    )
    return ThermalModelFile(
        method="regression",
        channels=CHANNELS,
        models=dict.fromkeys(CHANNELS, cm),
        use_gradient=False,
        derivative_window_s=60.0,
    )
