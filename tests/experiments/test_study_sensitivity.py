"""The sensitivity map's physical axes: the polynomial law's slopes read at the operating
point, a first-order Table-6 fit that recovers them exactly on a plant that is first order,
and the sweep factors carried into physical units."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from rinscal.experiments.paper.config import load_plant
from rinscal.experiments.study.sensitivity import (
    fit_sensitivities,
    plant_sensitivities,
    read_sensitivities,
    soak_fields,
)
from rinscal.experiments.study.spec import load_spec


def test_a_first_order_plant_is_recovered_by_the_table6_fit() -> None:
    """A plant whose bias is exactly a0 + a_T x + a_Ṫ r + a_ΔT d: the least-squares fit on
    the noise-free soak protocol returns the coefficients the law is read with."""
    base = load_plant("navigation_grade")
    rng = np.random.default_rng(5)
    thermal = tuple(
        replace(
            c,
            t=(float(rng.uniform(-2, 2)),),
            rate=(float(rng.uniform(-30, 30)),),
            grad=(float(rng.uniform(-8, 8)),),
            t_grad=0.0,
            t_rate=0.0,
            stress=0.0,
            rate_range=None,
            grad_range=None,
        )
        for c in base.thermal
    )
    cfg = replace(base, thermal=thermal)
    read, eq_read = read_sensitivities(cfg)
    fitted, eq_fit = fit_sensitivities(cfg, soak_fields(cfg, hours=1.0))
    assert fitted == pytest.approx(read, rel=1e-6, abs=1e-9)
    assert eq_fit == pytest.approx(eq_read, rel=1e-6)
    # the equivalents: mean magnitude over accel x, y and over the three gyros
    assert eq_read["accel_rate_ug_per_c_min"] == pytest.approx(np.mean(np.abs(read[3:5, 1])))
    assert eq_read["gyro_rate_dph_per_c_min"] == pytest.approx(np.mean(np.abs(read[0:3, 1])))


def test_read_slopes_include_the_coupling_to_t_at_the_operating_point() -> None:
    cfg = load_plant("navigation_grade")
    c = cfg.thermal[3]  # accel_x: rate (25, 6), t_rate 0.4, grad (-6, 0.8), t_grad 0.12
    read, _ = read_sensitivities(cfg, t_c=cfg.t_ref_c + 10.0)
    assert read[3, 1] == pytest.approx(c.rate[0] + 10.0 * c.t_rate)
    assert read[3, 2] == pytest.approx(c.grad[0] + 10.0 * c.t_grad)
    assert read[3, 0] == pytest.approx(sum((k + 1) * a * 10.0**k for k, a in enumerate(c.t)))


def test_sweep_factors_scale_the_physical_axes() -> None:
    """accel_dynamic_scale multiplies the accelerometers' Ṫ and ΔT terms (and their
    couplings): read at t_ref the equivalents scale by the factor exactly; gyro_rate_scale
    scales the gyros' Ṫ term. The mechanistic twin's fitted equivalents grow with the
    factor too (its dynamic terms are linear in the swept coefficients)."""
    spec = load_spec("sensitivity", quick=True)
    s = plant_sensitivities(spec)
    poly = s[s["law"] == "polynomial"]
    one = poly[poly["plant_label"] == "navigation_grade accel_dynamic_scale=1 gyro_rate_scale=1"]
    ten = poly[poly["plant_label"] == "navigation_grade accel_dynamic_scale=10 gyro_rate_scale=10"]
    one, ten = one.iloc[0], ten.iloc[0]
    for col in ("accel_rate_ug_per_c_min", "accel_grad_ug_per_c", "gyro_rate_dph_per_c_min"):
        assert ten[col] == pytest.approx(10.0 * one[col])
    assert one["accel_rate_ug_per_c_min"] == pytest.approx((25.0 + 18.0) / 2)
    mech = s[s["law"] == "mechanistic"].sort_values("accel_rate_ug_per_c_min")
    assert mech["source"].eq("fitted on the soak protocol").all()
    assert mech["accel_rate_ug_per_c_min"].is_monotonic_increasing
    assert mech["accel_rate_ug_per_c_min"].iloc[-1] > 10 * mech["accel_rate_ug_per_c_min"].iloc[0]
