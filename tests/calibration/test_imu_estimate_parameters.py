"""One channel's regression coefficients turned into the sensor model's parameters
(``rinscal.calibration.imu.estimate``): scale factor ``K_jj − 1``, misalignments
``K_jk / K_jj``, and their sds propagated through that division."""

from __future__ import annotations

import math

import numpy as np

from rinscal.calibration.imu.estimate import _to_parameters
from rinscal.sensormodel import parameter_spec


def _si(name: str, table_value: float) -> float:
    return table_value * parameter_spec(name).to_si


def test_a_row_of_the_matrix_gives_scale_factor_and_misalignments() -> None:
    coef = np.array([1e-5, 2e-4, 1.001, -3e-4])  # bias [rad/s], K_yx, K_yy, K_yz
    sd = 1e-6
    values, sds = _to_parameters("gyro", 1, coef, np.eye(4) * sd**2, nonlinear=False)
    assert list(values) == ["gyro_bias_y", "gyro_sf_y", "gyro_mis_yx", "gyro_mis_yz"]
    assert math.isclose(_si("gyro_bias_y", values["gyro_bias_y"]), 1e-5, rel_tol=1e-12)
    assert math.isclose(_si("gyro_sf_y", values["gyro_sf_y"]), 0.001, rel_tol=1e-9)
    assert math.isclose(_si("gyro_mis_yx", values["gyro_mis_yx"]), 2e-4 / 1.001, rel_tol=1e-12)
    assert math.isclose(_si("gyro_mis_yz", values["gyro_mis_yz"]), -3e-4 / 1.001, rel_tol=1e-12)
    # sd of K_yx / K_yy with independent sds s: s·sqrt(1/K_yy² + K_yx²/K_yy⁴)
    want = sd * math.sqrt(1 / 1.001**2 + (2e-4) ** 2 / 1.001**4)
    assert math.isclose(_si("gyro_mis_yx", sds["gyro_mis_yx"]), want, rel_tol=1e-9)
    assert math.isclose(_si("gyro_sf_y", sds["gyro_sf_y"]), sd, rel_tol=1e-9)
