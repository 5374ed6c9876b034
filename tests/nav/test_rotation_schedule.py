"""Turntable schedules and the r/b frame relation (paper Section 2, Eqs. 1-9)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rinscal.errors import ConfigError
from rinscal.nav.rotation import FOUR_POSITIONS_DEG, C_br, RotationSchedule

D2R = math.pi / 180


def test_C_br_is_eq1_and_orthonormal() -> None:
    phi = 0.7
    C = C_br(phi)
    expected = np.array(
        [[math.cos(phi), -math.sin(phi), 0], [math.sin(phi), math.cos(phi), 0], [0, 0, 1]]
    )
    np.testing.assert_allclose(C, expected, atol=0)
    np.testing.assert_allclose(C @ C.T, np.eye(3), atol=1e-15)
    # r coincides with b at zero angle
    np.testing.assert_array_equal(C_br(0.0), np.eye(3))


def test_four_position_visits_the_paper_positions_and_returns() -> None:
    s = RotationSchedule.four_position(dwell_s=60.0, rate_dps=10.0, accel_dps2=10.0)
    # dwell midpoints are at the four positions, in order
    dwell_mid = []
    t = 30.0
    starts = np.asarray(s.starts)
    for k, (_c0, c1, c2) in enumerate(s.coefs):
        if c1 == 0 and c2 == 0:
            dwell_mid.append(starts[k] + 30.0)
    angles = s.angle(np.asarray(dwell_mid)) / D2R
    np.testing.assert_allclose(angles, FOUR_POSITIONS_DEG, atol=1e-12)
    # one cycle later the table is back where it started (cable never winds up)
    for t in (30.0, 100.0, 170.0):
        np.testing.assert_allclose(s.angle(t + s.period), s.angle(t), atol=1e-9)
    # moves: +180 (9 + 18 - ... ) timing: 180° at 10°/s with 10°/s² takes 19 s, 90° takes 10 s
    assert s.period == pytest.approx(4 * 60 + 2 * 19 + 2 * 10)


def test_four_position_rate_and_accel_limits_and_consistency() -> None:
    s = RotationSchedule.four_position(dwell_s=20.0, rate_dps=8.0, accel_dps2=4.0)
    t = np.linspace(0, 3 * s.period, 200001)
    phi, rate, acc = s.evaluate(t)
    assert np.max(np.abs(rate)) <= 8.0 * D2R * (1 + 1e-12)
    assert np.max(np.abs(acc)) <= 4.0 * D2R * (1 + 1e-12)
    # angle is continuous and its numerical derivative equals the rate
    h = t[1] - t[0]
    # (trapezoid of the rate; at a break point the error is at most ½·accel·h)
    np.testing.assert_allclose(
        np.diff(phi) / h, 0.5 * (rate[1:] + rate[:-1]), atol=0.5 * 4.0 * D2R * h
    )
    # rate is continuous for the smooth profile
    assert np.max(np.abs(np.diff(rate))) < 4.0 * D2R * h * 1.01
    # the rotating unit vector averages to zero over the dwells (Eqs. 8-9 premise); the
    # moves leave a residual no larger than the fraction of time spent moving
    tc = np.linspace(0, s.period, 400001)
    ph, rt, _ = s.evaluate(tc)
    dwell = rt == 0
    assert abs(np.mean(np.cos(ph[dwell]))) < 1e-3
    assert abs(np.mean(np.sin(ph[dwell]))) < 1e-3
    moving = 1.0 - dwell.mean()
    assert abs(np.mean(np.cos(ph))) < moving
    assert abs(np.mean(np.sin(ph))) < moving


def test_constant_rate_moves_step_the_rate() -> None:
    s = RotationSchedule.four_position(dwell_s=10.0, rate_dps=10.0, accel_dps2=None)
    _, rate, acc = s.evaluate(np.array([5.0, 10.5, 27.0]))
    np.testing.assert_allclose(rate, [0.0, 10 * D2R, 10 * D2R])
    np.testing.assert_array_equal(acc, 0.0)
    assert s.period == pytest.approx(4 * 10 + (180 + 90 + 180 + 90) / 10)


def test_continuous_and_none() -> None:
    s = RotationSchedule.continuous(rate_dps=6.0)
    t = np.array([0.0, 10.0, 61.0, 1000.0])
    np.testing.assert_allclose(s.angle(t), 6 * D2R * t, rtol=1e-13)
    np.testing.assert_allclose(s.rate(t), 6 * D2R)
    n = RotationSchedule.none(30.0)
    np.testing.assert_allclose(n.angle(t), 30 * D2R)
    assert n.breakpoints(0, 1e6).size == 0


def test_breakpoints_and_start_delay() -> None:
    s = RotationSchedule.four_position(dwell_s=60.0, t_start=100.0)
    np.testing.assert_allclose(s.angle([0.0, 50.0, 99.0]), -135 * D2R)
    bp = s.breakpoints(0.0, 100.0 + s.period)
    assert bp[0] == pytest.approx(100.0)
    assert bp[1] == pytest.approx(160.0)  # end of the first dwell
    assert np.all(np.diff(bp) > 0)


def test_invalid_schedules_raise() -> None:
    with pytest.raises(ConfigError, match="dwell_s"):
        RotationSchedule.four_position(dwell_s=-1)
    with pytest.raises(ConfigError, match="rate_dps"):
        RotationSchedule.continuous(rate_dps=0)
    with pytest.raises(ConfigError, match="starts"):
        RotationSchedule("bad", (1.0,), ((0.0, 0.0, 0.0),))
