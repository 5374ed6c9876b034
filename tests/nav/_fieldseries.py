"""Bias series of parked cold starts as the field estimator would give them at best: the
plant's own total equivalent error on the static base (thermal bias, the scale-factor and
misalignment terms of Earth rate and gravity, turn-on offset) plus white scatter of a given
sd, with the plant's thermometer readings (for the fit and observability tests, which do not
run the estimator)."""

from __future__ import annotations

import numpy as np

from rinscal import earth
from rinscal.nav.fieldbias import BiasSeries
from rinscal.nav.rotation import RotationSchedule
from rinscal.sim.config import load_imu
from rinscal.sim.field import ChamberProfile
from rinscal.sim.sensors import ThermalPlant

LAT = np.deg2rad(32.06)
#: Scatter of the series, 1σ [rad/s ×3, m/s² ×3]: about the smoother's on a 4 h start.
SD = np.array([3 * 4.8e-9] * 3 + [5 * 9.8e-6] * 3)


def true_series(
    ambients: tuple[float, ...], hours: float = 4.0, step_s: float = 10.0, seed: int = 0,
    imu: str = "paper",
) -> dict[str, tuple[BiasSeries, np.ndarray]]:  # fmt: skip
    """Start name → (series with scatter SD, the true error (m, 6) [SI])."""
    cfg = load_imu(imu)
    sch = RotationSchedule.four_position()
    rng = np.random.default_rng(seed)
    out = {}
    for k, amb in enumerate(ambients):
        p = ThermalPlant(cfg, ChamberProfile.constant(amb), hours * 3600, 1 / step_s,
                         seed=seed + k, noise=False, schedule=sch)  # fmt: skip
        t = np.arange(step_s, hours * 3600 + 1e-9, step_s)
        yaw = np.deg2rad(37.0 * k + 10.0) + sch.angle(t)
        w = earth.RATE * np.cos(LAT)
        omega = np.column_stack(
            [-w * np.sin(yaw), w * np.cos(yaw), np.full_like(t, earth.RATE * np.sin(LAT))]
        )
        f = np.column_stack([0 * t, 0 * t, earth.gravity(LAT) + 0 * t])
        e = p.thermal_errors(t, omega, f) + p.offsets
        inner, outer = p.measured_temperatures(t)
        n = t.size
        s = BiasSeries(t, e + rng.standard_normal((n, 6)) * SD, np.tile(SD, (n, 1)), inner, outer,
                       np.zeros((n, 3)), np.zeros((n, 3)), 300.0)  # fmt: skip
        out[f"start_{k}"] = (s, e)
    return out
