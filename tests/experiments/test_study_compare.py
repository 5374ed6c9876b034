"""Paired comparisons against a reference: Student-t intervals over units checked against
scipy's own, the verdict at the boundary of the sample size, known differences recovered,
and each unit's soak design against the bound its correlation sets."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from rinscal.experiments.study.compare import (
    MIN_SAMPLES,
    decide,
    fmt_interval,
    median_ratio,
    paired_against,
    t_interval,
)
from rinscal.experiments.study.tasks import soak_design
from rinscal.thermal.protocols import simulate_protocol


def test_t_interval_is_students_and_needs_min_samples() -> None:
    x = np.array([0.31, -0.12, 0.45, 0.08, 0.27, 0.19, -0.05])
    lo, hi = t_interval(x)
    want = stats.t.interval(0.95, x.size - 1, loc=x.mean(), scale=stats.sem(x))
    assert (lo, hi) == pytest.approx(want, rel=1e-12)
    # by hand: mean ± t(0.975, 6) s / √7, t(0.975, 6) = 2.446912
    h = 2.446912 * x.std(ddof=1) / math.sqrt(7)
    assert lo == pytest.approx(x.mean() - h, rel=1e-6)
    assert MIN_SAMPLES == 5
    assert all(math.isnan(v) for v in t_interval(x[:4]))
    assert all(math.isfinite(v) for v in t_interval(x[:5]))
    assert t_interval(np.full(6, 0.2)) == (0.2, 0.2)


def test_verdict_at_the_boundary_of_the_sample_size() -> None:
    assert decide(4, -0.3, -0.1, "no compensation", "m2") == (
        "not enough units for an interval (n = 4; needs 5)"
    )
    assert decide(5, -0.3, -0.1, "no compensation", "m2") == "m2 beats no compensation (resolved)"
    assert decide(5, 0.1, 0.3, "no compensation", "m2") == "no compensation beats m2 (resolved)"
    assert decide(5, -0.1, 0.3, "no compensation", "m2") == "no resolved difference"
    assert decide(9, math.nan, math.nan, "a", "b").startswith("not enough units")
    assert fmt_interval(-0.1149, -0.031, 2) == "[−0.11, −0.03]"
    assert fmt_interval(math.nan, 1.0, 2) == ""


def _results(n_units: int, starts: int = 2) -> pd.DataFrame:
    """Per run: none = 1 + u/10 + noise, regression = none − 0.2 (− 0.1 on start 1),
    poly-t = none + 0.05, true = 0.3·none."""
    rng = np.random.default_rng(3)
    rows = []
    for u in range(n_units):
        for s in range(starts):
            none = 1.0 + u / 10 + rng.normal(0, 0.05)
            vals = {
                "none": none,
                "poly-t": none + 0.05,
                "regression": none - 0.2 - 0.1 * s,
                "true": 0.3 * none,
            }
            for v, e in vals.items():
                rows.append(
                    {
                        "plant": 0,
                        "plant_label": "p",
                        "unit": u,
                        "scenario": "qs",
                        "start": s,
                        "align_start_s": 1800.0,
                        "variant": v,
                        "max_error_nmi": e,
                    }
                )
    return pd.DataFrame(rows)


def test_paired_against_recovers_known_differences_and_counts() -> None:
    c = paired_against(_results(6)).set_index(["reference", "method"])
    r = c.loc[("none", "regression")]
    # pair within a run, average within a unit: −0.2 and −0.3 average to −0.25 in every unit
    assert r["delta"] == pytest.approx(-0.25)
    assert (r["delta ci low"], r["delta ci high"]) == pytest.approx((-0.25, -0.25))
    assert r["n units"] == 6 and r["n runs"] == 12
    assert r["units method better"] == 6 and r["runs method better"] == 12
    assert r["verdict"] == "method 2 (regression) beats no compensation (resolved)"
    assert r["align_start_s"] == 1800.0
    r = c.loc[("poly-t", "regression")]
    assert r["delta"] == pytest.approx(-0.30)
    r = c.loc[("none", "poly-t")]
    assert r["verdict"] == "no compensation beats baseline (cubic in T) (resolved)"
    assert ("none", "true") not in c.index  # the oracle is a reference, not a method
    # with 3 units: point estimates, no interval, the verdict says why
    c3 = paired_against(_results(3)).set_index(["reference", "method"])
    r = c3.loc[("none", "regression")]
    assert r["delta"] == pytest.approx(-0.25) and math.isnan(r["delta ci low"])
    assert r["verdict"] == "not enough units for an interval (n = 3; needs 5)"


def test_oracle_against_none_is_a_paired_difference() -> None:
    res = _results(8)
    o = paired_against(res, ("true",), ("none",)).iloc[0]
    unit_none = res[res["variant"] == "none"].groupby("unit")["max_error_nmi"].mean()
    d = 0.7 * unit_none  # none − 0.3·none per run, averaged per unit
    assert o["delta"] == pytest.approx(d.mean())
    assert (o["delta ci low"], o["delta ci high"]) == pytest.approx(
        stats.t.interval(0.95, 7, loc=d.mean(), scale=stats.sem(d))
    )
    assert o["runs method better"] == 0  # the oracle never lost a run here


def test_median_ratio() -> None:
    a = np.array([1.0, 2.0, 3.0, 4.0, 50.0])
    r, lo, hi = median_ratio(a, 0.5 * a)
    assert r == pytest.approx(0.5) and lo == pytest.approx(0.5) and hi == pytest.approx(0.5)
    r, lo, hi = median_ratio(a[:3], a[:3] * 2)
    assert r == pytest.approx(2.0) and math.isnan(lo)


def test_soak_design_condition_number_is_bounded_by_the_correlation() -> None:
    """For standardised columns, the condition number of [T, Ṫ, ΔT] is at least that of the
    pair (Ṫ, ΔT), sqrt((1 + |r|)/(1 − |r|)) for their correlation r."""
    log, _, _ = simulate_protocol("soak", hours=0.5, rate_hz=1.0, seed=1, imu="navigation_grade")
    d = soak_design(log)
    r, k = d["soak_rate_grad_corr"], d["soak_design_cond"]
    assert -1.0 < r < 1.0 and abs(r) > 0.1  # a warm-up: the rate and the gradient move together
    assert k >= math.sqrt((1 + abs(r)) / (1 - abs(r))) * (1 - 1e-9)
    nograd = soak_design(log.drop(columns=["temp_out"]))
    assert all(math.isnan(v) for v in nograd.values())
