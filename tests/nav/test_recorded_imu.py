"""Recorded navigation applies a model file's IMU calibration as the other compensators do:
the increments it hands the strapdown are the true ones, piece by piece."""

from __future__ import annotations

import numpy as np

from rinscal.calibration.imustage import ImuStage
from rinscal.nav.recorded.compensation import CausalModelCompensator
from rinscal.schema import NavSamples
from tests.calibration._imucal import PHYSICAL, calibration, forward, pulse_meta
from tests.calibration.test_imu_model import BETA0, BETA1, _model, _static_reference


def test_recorded_compensation_applies_the_imu_calibration_then_the_thermal_bias() -> None:
    rate_hz, n = 10.0, 1200
    t = (np.arange(n) + 1.0) / rate_hz
    dt = np.full(n, 1.0 / rate_hz)
    tick = np.floor(t - 0.5 / rate_hz + 1e-9)  # the thermometers are read once a second
    temp = np.column_stack([5.0 + 35.0 * (0.5 + 0.5 * np.sin(tick / 40.0 + j)) for j in range(6)])
    s = _static_reference() + np.column_stack(
        [100 * 3600 * np.sin(t * (0.6 + 0.1 * j)) for j in range(3)]
        + [1.2e6 * np.cos(t * (0.4 + 0.1 * j)) for j in range(3)]
    )  # deg/h, µg
    beta = BETA0 + BETA1 * (temp - 20.0)
    y = forward((s + beta) * PHYSICAL, temp)  # what the unit puts out [SI]
    meta = pulse_meta(rate_hz)
    comp = CausalModelCompensator(
        _model(ImuStage(calibration(), meta["units"], meta["unit_to_si"])), policy="extrapolate"
    )
    got = []
    for a, b in ((0, 137), (137, 700), (700, n)):  # pieces that cut the seconds
        piece = NavSamples(
            t=t[a:b],
            dt=dt[a:b],
            dtheta=y[a:b, :3] * dt[a:b, None],
            dv=y[a:b, 3:] * dt[a:b, None],
            temps=temp[a:b],
        )
        c = comp(piece)
        got.append(np.column_stack([piece.dtheta, piece.dv]) / dt[a:b, None] - c)
    rates = np.concatenate(got) / PHYSICAL  # deg/h, µg
    scale = np.abs(s).max()
    np.testing.assert_allclose(rates, s, rtol=0, atol=1e-9 * scale)
    # control: the thermal model alone leaves the scale-factor and misalignment errors
    alone = CausalModelCompensator(_model(None), policy="extrapolate")
    piece = NavSamples(t=t, dt=dt, dtheta=y[:, :3] * dt[:, None], dv=y[:, 3:] * dt[:, None],
                       temps=temp)  # fmt: skip
    off = (y - alone(piece)) / PHYSICAL - s
    assert np.abs(off[:, 0]).max() > 30.0 and np.abs(off[:, 3]).max() > 100.0
