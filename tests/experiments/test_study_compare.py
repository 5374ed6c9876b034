"""Paired comparisons against a reference: Student-t intervals over units checked against
scipy's own, the verdict at the boundary of the sample size, known differences recovered,
and each unit's soak design against the bound its correlation sets."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from rinscal.experiments.study.compare import fmt_interval, median_ratio, paired_against
from rinscal.experiments.study.tasks import soak_design
from rinscal.sim.protocols import simulate_protocol


def test_fmt_interval() -> None:
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
    assert r["verdict"] == "holds"  # method 2 better than no compensation
    assert r["align_start_s"] == 1800.0
    r = c.loc[("poly-t", "regression")]
    assert r["delta"] == pytest.approx(-0.30)
    r = c.loc[("none", "poly-t")]
    assert r["verdict"] == "reversed"  # the cubic in T better than no compensation
    assert ("none", "true") not in c.index  # the oracle is a reference, not a method
    # with 3 units: point estimates, no interval, the verdict says why
    c3 = paired_against(_results(3)).set_index(["reference", "method"])
    r = c3.loc[("none", "regression")]
    assert r["delta"] == pytest.approx(-0.25) and math.isnan(r["delta ci low"])
    assert r["verdict"] == "not enough runs"


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
