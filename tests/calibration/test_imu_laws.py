"""Each IMU parameter's law in temperature (``rinscal.calibration.imu.laws``): the simplest
law the held-out estimates support, on parameters whose law is known."""

from __future__ import annotations

import math

import numpy as np

from rinscal.calibration.imu.laws import fit_law

TEMPS = np.array([-20.0, -5.0, 10.0, 25.0, 40.0, 55.0, 70.0])  # [°C]


def test_a_linear_parameter_gets_a_line_through_its_values() -> None:
    rng = np.random.default_rng(3)
    sd = np.full(TEMPS.size, 0.02)  # [ppm]
    values = 5.0 + 0.3 * (TEMPS - 25.0) + rng.normal(0.0, 0.02, TEMPS.size)
    law = fit_law(TEMPS, values, sd, t0_c=25.0)
    assert (law.degree, law.rate_degree) == (1, 0)
    # least squares of 7 points: sd of the slope 0.02/sqrt(sum dx^2) = 2.7e-4 ppm/°C
    assert abs(law.t_coefs[1] - 0.3) < 4 * 0.02 / math.sqrt(np.sum((TEMPS - 25.0) ** 2))
    assert abs(law.t_coefs[0] - 5.0) < 4 * 0.02 / math.sqrt(TEMPS.size)
    assert set(law.scores) == {"T0", "T1", "T2", "T3"}  # n - 3 = 4, capped at max_degree 3
    assert law.scores["T0"] > 100 * law.heldout_score  # the constant misses by far


def test_a_rate_term_is_kept_where_the_rate_explains_the_values() -> None:
    rate = np.array([0.5, -0.5, 0.5, -0.5, 0.5, -0.5, 0.5])  # [°C/min], alternating ramps
    values = 1.0 + 0.01 * (TEMPS - 25.0) + 0.4 * rate
    law = fit_law(TEMPS, values, np.full(TEMPS.size, 1e-3), 25.0, tdot_c_per_min=rate)
    assert law.rate_degree == 1
    assert math.isclose(law.rate_coefs[0], 0.4, rel_tol=1e-6)
    flat = fit_law(TEMPS, values, np.full(TEMPS.size, 1e-3), 25.0, tdot_c_per_min=rate * 0)
    assert flat.rate_degree == 0 and not any("rate" in k for k in flat.scores)


def test_one_temperature_gives_its_value_as_a_constant() -> None:
    law = fit_law(np.array([20.0]), np.array([7.5]), np.array([0.1]), 25.0)
    assert law.t_coefs == (7.5,) and law.degree == 0 and math.isnan(law.heldout_score)
