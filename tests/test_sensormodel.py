"""The sensor-error model and the turntable geometry against textbook values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rinscal import turntable
from rinscal.errors import ConfigError
from rinscal.sensormodel import (
    PARAMETERS,
    ImuCalibration,
    TriadErrors,
    parameter_spec,
    triad_forward,
    triad_inverse,
)

OMEGA = 7.292115e-5  # WGS84 Earth rate [rad/s]
LAT = math.radians(32.06)


def _errors(rng: np.random.Generator) -> TriadErrors:
    mis = rng.normal(0, 50e-6, (3, 3))
    np.fill_diagonal(mis, 0.0)
    return TriadErrors(
        bias=rng.normal(0, 1e-6, 3),
        sf=rng.normal(0, 100e-6, 3),
        asym=rng.normal(0, 5e-6, 3),
        quad=rng.normal(0, 1e-6, 3),
        mis=mis,
    )


def test_inverse_undoes_forward_to_machine_precision() -> None:
    rng = np.random.default_rng(1)
    e = _errors(rng)
    s = rng.normal(0, 3.0, (500, 3))
    np.testing.assert_allclose(triad_inverse(triad_forward(s, e), e), s, rtol=0, atol=1e-14)


def test_linear_part_is_pyins_transform_T_times_s_plus_b() -> None:
    # y = b + (I + K)(I + M) s when the nonlinear terms are zero (pyins' x_out = T x + b)
    rng = np.random.default_rng(2)
    e = _errors(rng)
    e = TriadErrors(bias=e.bias, sf=e.sf, mis=e.mis)
    s = rng.normal(0, 1.0, (10, 3))
    big_t = np.diag(1 + e.sf) @ (np.eye(3) + e.mis)
    np.testing.assert_allclose(triad_forward(s, e), s @ big_t.T + e.bias, rtol=1e-14)
    np.testing.assert_allclose(e.matrix(), big_t)


def test_asymmetry_and_quadratic_terms_as_defined() -> None:
    # +1 rad/s and -1 rad/s: scale factors 1 + k + a and 1 + k - a; quadratic q u^2
    e = TriadErrors(sf=np.full(3, 1e-4), asym=np.full(3, 2e-5), quad=np.zeros(3))
    y = triad_forward(np.array([[1.0, -1.0, 0.5]]), e)[0]
    np.testing.assert_allclose(y, [1 + 1e-4 + 2e-5, -(1 + 1e-4 - 2e-5), 0.5 * (1 + 1.2e-4)])
    q = TriadErrors(quad=np.full(3, 3e-7))
    np.testing.assert_allclose(
        triad_forward(np.array([2.0, -2.0, 0.0]), q), [2 + 1.2e-6, -2 + 1.2e-6, 0]
    )


def test_units_of_the_named_parameters() -> None:
    # 1 ppm/(deg/s) at 100 deg/s is a 100 ppm scale-factor error
    q = parameter_spec("gyro_sf_quad_x").to_si
    w = math.radians(100.0)
    assert q * w == pytest.approx(100e-6)
    # 10 ug/g^2 at 1 g is 10 ug
    qa = parameter_spec("accel_sf_quad_z").to_si
    assert 10 * qa * 9.80665**2 == pytest.approx(10 * 9.80665e-6)
    assert parameter_spec("gyro_mis_xy").to_si == pytest.approx(math.pi / 648000)
    assert len(PARAMETERS) == 33
    names = {p.name for p in PARAMETERS}
    assert {"gyro_mis_xy", "gyro_mis_zy", "accel_mis_yx", "gyro_sf_asym_z"} <= names
    assert "accel_sf_asym_x" not in names
    with pytest.raises(ConfigError, match="unknown IMU parameter 'gyro_sf_w'"):
        parameter_spec("gyro_sf_w")


def test_calibration_laws_clamp_relative_and_round_trip() -> None:
    cal = ImuCalibration(
        24.0, (0.0, 48.0), {"gyro_sf_x": (10.0, 0.5, 0.01), "accel_mis_xy": (20.0, 0.1)}
    )
    assert cal.value("gyro_sf_x", 34.0) == pytest.approx(10 + 5 + 1)
    assert cal.value("gyro_sf_x", 100.0) == pytest.approx(cal.value("gyro_sf_x", 48.0))
    rel = cal.relative_to(20.0)
    assert rel.value("gyro_sf_x", 20.0) == pytest.approx(0.0, abs=1e-12)
    assert rel.value("gyro_sf_x", 40.0) == pytest.approx(
        cal.value("gyro_sf_x", 40.0) - cal.value("gyro_sf_x", 20.0)
    )
    gyro, accel = cal.triads(np.full(6, 34.0))
    assert gyro.sf[0] == pytest.approx(16e-6)
    assert accel.mis[0, 1] == pytest.approx(21.0 * math.pi / 648000)
    assert ImuCalibration.from_dict(cal.to_dict()) == cal
    with pytest.raises(ConfigError, match=r"imu\.json: not an IMU calibration"):
        ImuCalibration.from_dict({"schema": "x"}, "imu.json")
    bad = cal.to_dict()
    bad["units"]["gyro_sf_x"] = "ppb"
    with pytest.raises(ConfigError, match="gyro_sf_x is in 'ppb'"):
        ImuCalibration.from_dict(bad, "imu.json")


def test_correct_removes_a_known_calibration() -> None:
    rng = np.random.default_rng(3)
    cal = ImuCalibration(
        20.0,
        (-10.0, 60.0),
        {p.name: (float(rng.normal(0, 30)), float(rng.normal(0, 0.5))) for p in PARAMETERS},
    )
    temp = rng.uniform(0, 40, (200, 6))
    s = np.concatenate([rng.normal(0, 1, (200, 3)), rng.normal(0, 9.8, (200, 3))], axis=1)
    g, a = cal.triads(temp)
    y = np.concatenate([triad_forward(s[:, :3], g), triad_forward(s[:, 3:], a)], axis=1)
    np.testing.assert_allclose(cal.correct(y, temp), s, rtol=0, atol=1e-12)


def test_turntable_positions_feel_gravity_and_earth_rate_as_textbook() -> None:
    g = 9.794860  # normal gravity at 32.06 N, 10 m (rinscal's data/paper.toml comment)
    wn, wu = OMEGA * math.cos(LAT), OMEGA * math.sin(LAT)
    # heading 0: at (0, 0) x east, y north, z up
    cases = {
        (0.0, 0.0): ((0, 0, g), (0, wn, wu)),
        (-90.0, 0.0): ((g, 0, 0), (wu, wn, 0)),  # x up, y still north
        (180.0, 0.0): ((0, 0, -g), (0, wn, -wu)),
        (90.0, 90.0): ((0, g, 0), (wn, wu, 0)),
    }
    for (o, i), (f_want, w_want) in cases.items():
        w, f = turntable.reference_r(o, i, LAT, 0.0, 10.0)
        np.testing.assert_allclose(f, f_want, atol=2e-5 * g, err_msg=f"f at {(o, i)}")
        np.testing.assert_allclose(w, w_want, atol=1e-12, err_msg=f"omega at {(o, i)}")


def test_turntable_rate_is_felt_about_the_turning_axis() -> None:
    # the outer axis is IMU y at inner 0 and IMU x at inner 90°; the inner axis is IMU z
    w = turntable.table_rate_r(0.0, 10.0, 0.0)
    np.testing.assert_allclose(w, [0, math.radians(10), 0], atol=1e-15)
    w = turntable.table_rate_r(90.0, 10.0, 0.0)
    np.testing.assert_allclose(w, [math.radians(10), 0, 0], atol=1e-15)
    w = turntable.table_rate_r(33.0, 0.0, -5.0)
    np.testing.assert_allclose(w, [0, 0, math.radians(-5)], atol=1e-15)
