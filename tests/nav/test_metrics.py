"""The navigation metrics against values computed here from first principles, and the
textbook gyrocompass formula against the alignment filter itself.

The gyrocompass test is the controlled case of the reproduction's mechanism table: an
otherwise ideal IMU, fixed (the turntable holds still), whose only error is a linear
accelerometer bias ramp (or a constant east gyro bias) during the alignment. The expected
heading error is computed here from the levelled components of the ramp, independently of
:func:`rinscal.nav.metrics.gyrocompass_heading_error`.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from rinscal import earth, units
from rinscal.nav.align import AlignConfig
from rinscal.nav.metrics import (
    cep50,
    drift_rate,
    gyrocompass_heading_error,
    max_change_within,
    slope,
)
from rinscal.nav.rotation import RotationSchedule
from rinscal.sim.scenario import preset, run_scenario

RAMP_UG_MIN = 10.0


def _heading_with(errors_fn, rotate: bool) -> tuple[float, object]:
    """Heading error at navigation start [″] of a quasi-static run (heading 45°, 10 Hz)."""
    sched = RotationSchedule.four_position() if rotate else RotationSchedule.none()
    cfg = preset("quasi-static", hours=0.25, rate_hz=10.0, align=AlignConfig(), schedule=sched)
    cfg = replace(cfg, out_dt_s=10.0)
    res = run_scenario(cfg, errors_fn)
    return res.summary()["variants"]["none"]["attitude_error_at_nav_start"]["heading_arcsec"], cfg


def _ramp(axis: int, k: float):
    def err(t, w, f):
        e = np.zeros((t.shape[0], 6))
        e[:, axis] = k * t
        return e

    return err


@pytest.mark.parametrize("axis", [3, 4])
def test_fixed_imu_gyrocompass_heading_error_matches_the_textbook(axis: int) -> None:
    k = RAMP_UG_MIN * units.UG_TO_MPS2 / 60.0  # [m/s³]
    measured, cfg = _heading_with(_ramp(axis, k), rotate=False)
    lat = cfg.trajectory.lat0
    # the IMU's x axis (right) points at azimuth 45° + 90°, its y axis (forward) at 45°
    az = math.radians(135.0 if axis == 3 else 45.0)
    k_n, k_e = k * math.cos(az), k * math.sin(az)
    g = float(earth.gravity(lat, cfg.trajectory.alt0))
    t_end = cfg.align.total_s
    # textbook, written out here: δψ = ∇̇_N / (g Ω cos L) + tan L ∇_E(end) / g
    expected = k_n / (g * earth.RATE * math.cos(lat)) + math.tan(lat) * k_e * t_end / g
    expected /= units.ARCSEC_TO_RAD
    assert abs(expected) > 300  # a large, unambiguous effect (≈ ±390″)
    # within 3 %: the filter's finite bandwidth lags a ramp a little
    assert measured == pytest.approx(expected, rel=0.03)
    via_lib = gyrocompass_heading_error(lat, accel_rate_n=k_n, accel_e=k_e * t_end, g=g)
    assert via_lib / units.ARCSEC_TO_RAD == pytest.approx(expected, rel=1e-12)


def test_fixed_imu_east_gyro_bias_gives_minus_eps_over_earth_rate() -> None:
    eps = 0.001 * units.DPH_TO_RPS

    def err(t, w, f):
        e = np.zeros((t.shape[0], 6))
        e[:, 0] = eps  # x gyro: points at azimuth 135°, east component sin 135°
        return e

    measured, cfg = _heading_with(err, rotate=False)
    lat = cfg.trajectory.lat0
    expected = -eps * math.sin(math.radians(135.0)) / (earth.RATE * math.cos(lat))
    expected /= units.ARCSEC_TO_RAD  # ≈ −11.4″
    assert measured == pytest.approx(expected, rel=0.05)


def test_rotating_alignment_takes_up_most_of_a_ramp() -> None:
    """With the four-position modulation the horizontal biases are observable and the
    filter's Gauss-Markov bias states follow a drift: the fixed-IMU formula overstates the
    heading error (the reproduction's mechanism table says so in words)."""
    k = RAMP_UG_MIN * units.UG_TO_MPS2 / 60.0
    fixed, _ = _heading_with(_ramp(3, k), rotate=False)
    rotating, _ = _heading_with(_ramp(3, k), rotate=True)
    assert abs(rotating) < 0.3 * abs(fixed)


def test_drift_rate_recovers_a_known_slope() -> None:
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 7200.0, 10.0)
    r = 50.0 + 0.2 * t + rng.normal(0.0, 20.0, t.size)  # 0.2 m/s = 0.389 nmi/h
    assert drift_rate(t, r) == pytest.approx(0.2, rel=0.02)
    assert np.isnan(drift_rate([1.0], [2.0]))
    two = slope(t, np.column_stack([t, -3 * t]))
    np.testing.assert_allclose(two, [1.0, -3.0], rtol=1e-12)


def test_cep_is_the_median_radius_of_a_circular_normal_group() -> None:
    # radial error of a circular normal σ: Rayleigh, median σ √(2 ln 2) = 1.1774 σ
    rng = np.random.default_rng(2)
    xy = rng.normal(0.0, 3.0, (40000, 2))
    assert cep50(np.hypot(*xy.T)) == pytest.approx(3.0 * math.sqrt(2 * math.log(2)), rel=0.02)
    assert math.isnan(cep50([]))


def test_max_change_within_a_period() -> None:
    t = np.arange(0.0, 3600.0, 1.0)
    y = np.column_stack([2.0 * t, np.sin(2 * np.pi * t / 600.0)])
    ch = max_change_within(t, y, 300.0)
    assert ch[0] == pytest.approx(600.0)  # a ramp changes by k W in any window W
    assert ch[1] == pytest.approx(2.0, abs=1e-3)  # half a sine period holds a full swing
    assert max_change_within(t, y, 1.0)[0] == pytest.approx(2.0)
