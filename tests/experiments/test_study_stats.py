"""Study statistics against values known in advance: interval coverage at its nominal rate,
exact paired decreases, verdicts in words."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from rinscal.experiments.study.stats import (
    MIN_SAMPLES,
    bootstrap_ci,
    claim_verdict,
    claims_table,
    method_summary,
    paired_decrease_ci,
    paired_differences,
    resolved,
    uncompensated_wins,
)


def test_bootstrap_interval_covers_a_known_mean_at_its_nominal_rate() -> None:
    """Skewed data (gamma, shape 4, like position errors) with a known mean of 2.0: the 95 %
    interval over 25 values must cover it about 95 % of the time."""
    rng = np.random.default_rng(42)
    reps, n, true_mean = 300, 25, 2.0
    hits = 0
    for i in range(reps):
        x = rng.gamma(4.0, true_mean / 4.0, n)
        lo, hi = bootstrap_ci(x, seed=i)
        hits += lo <= true_mean <= hi
    coverage = hits / reps
    # binomial sd at 0.95 over 300 repetitions is 0.013; BCa is slightly liberal at n = 25
    assert 0.90 <= coverage <= 0.99, coverage


def test_paired_decrease_interval_covers_the_true_decrease() -> None:
    """b = 0.7·a + noise: the decrease of the mean from a to b is 30 % (E[b] = 0.7 E[a])."""
    rng = np.random.default_rng(7)
    reps, n, hits = 200, 30, 0
    for i in range(reps):
        a = rng.gamma(5.0, 0.2, n)  # mean 1
        b = 0.7 * a + rng.normal(0.0, 0.05, n)
        lo, hi = paired_decrease_ci(a, b, seed=i)
        hits += lo <= 30.0 <= hi
    assert 0.89 <= hits / reps <= 0.99, hits / reps


def test_too_few_or_constant_values() -> None:
    lo, hi = bootstrap_ci(np.arange(MIN_SAMPLES - 1.0))
    assert math.isnan(lo) and math.isnan(hi)
    assert bootstrap_ci(np.full(10, 3.0)) == (3.0, 3.0)
    assert resolved(float("nan"), 1.0) == "not resolved"
    assert resolved(0.1, 2.0) == "b better"
    assert resolved(-2.0, -0.1) == "a better"
    assert resolved(-1.0, 1.0) == "not resolved"


def _results(n_units: int = 8, starts: int = 2) -> pd.DataFrame:
    """Synthetic results: per run, sectional = 1 + unit/10, regression = half of it,
    neural = regression + 0.01, none = 2 × sectional, true = 0.1."""
    rows = []
    for u in range(n_units):
        for r in range(starts):
            sec = 1.0 + u / 10.0 + r / 100.0
            values = {
                "none": 2 * sec,
                "sectional": sec,
                "regression": sec / 2,
                "neural": sec / 2 + 0.01,
                "true": 0.1,
            }
            for v, e in values.items():
                rows.append(
                    {
                        "plant": 0,
                        "plant_label": "p",
                        "unit": u,
                        "scenario": "lab qs",
                        "kind": "quasi-static",
                        "start": r,
                        "variant": v,
                        "max_error_nmi": e,
                        "thermal_part_nmi": abs(e - 0.1),
                        "heading_error_arcsec": -10.0 * e,
                    }
                )
    return pd.DataFrame(rows)


def test_paired_differences_recover_a_known_decrease() -> None:
    res = _results()
    pairs = paired_differences(res).set_index(["metric", "a", "b"])
    r = pairs.loc[("max_error_nmi", "sectional", "regression")]
    assert r["decrease %"] == pytest.approx(50.0)
    assert r["decrease ci low"] == pytest.approx(50.0)
    assert r["decrease ci high"] == pytest.approx(50.0)
    assert r["units b better"] == 8 and r["runs b better"] == 16  # counts, of 8 and 16
    assert r["n units"] == 8 and r["n runs"] == 16
    assert r["best decrease over the runs %"] == pytest.approx(50.0)
    # regression → neural: neural is worse by exactly 0.01 nmi in every run
    r = pairs.loc[("max_error_nmi", "regression", "neural")]
    assert r["difference"] == pytest.approx(-0.01)
    assert r["diff ci low"] == pytest.approx(-0.01) and r["diff ci high"] == pytest.approx(-0.01)
    assert r["units b better"] == 0
    # the |heading error| metric exists and is paired too
    r = pairs.loc[("abs_heading_error_arcsec", "none", "sectional")]
    assert r["decrease %"] == pytest.approx(50.0)


def test_method_summary_averages_starts_per_unit() -> None:
    res = _results(n_units=6, starts=3)
    s = method_summary(res)
    row = s[(s["metric"] == "max_error_nmi") & (s["variant"] == "sectional")].iloc[0]
    unit_means = np.array([1.0 + u / 10.0 + 0.01 for u in range(6)])  # mean of r/100, r<3
    assert row["n units"] == 6 and row["n runs"] == 18
    assert row["mean"] == pytest.approx(unit_means.mean())
    assert row["ci low"] < row["mean"] < row["ci high"]
    assert row["min"] == pytest.approx(1.0) and row["max"] == pytest.approx(1.52)
    # the oracle's thermal part is zero by construction and is not summarised
    tp = s[s["metric"] == "thermal_part_nmi"]
    assert "true" not in set(tp["variant"])


def test_claims_and_verdicts_in_words() -> None:
    res = _results()
    pairs = paired_differences(res)
    claims = claims_table(res, pairs)
    m12 = claims[claims["claim"].str.startswith("method 1 (sectional) → method 2")].iloc[0]
    assert m12["ours: mean decrease %"] == pytest.approx(50.0)
    assert m12["verdict"].startswith("direction holds: 50 % less on average")
    assert "best run" in m12["verdict"]
    m23 = claims[claims["claim"].str.startswith("method 2 (regression) → method 3")].iloc[0]
    assert m23["verdict"].startswith("reversed")
    r = pd.Series({"b": "neural", "decrease %": 5.0, "best decrease over the runs %": 40.0})
    assert claim_verdict(17.0, "up to", -3.0, 12.0, r).startswith("not shown: the interval")
    assert "lies inside" in claim_verdict(56.0, "mean", 40.0, 60.0, pd.Series({"decrease %": 50.0}))
    assert "lies above" in claim_verdict(56.0, "mean", 10.0, 30.0, pd.Series({"decrease %": 20.0}))
    assert claim_verdict(56.0, "mean", math.nan, math.nan, r).startswith("undecided")
    r4 = pd.Series({"n units": 4, "decrease %": 5.0})
    assert claim_verdict(56.0, "mean", math.nan, math.nan, r4) == (
        "undecided: not enough units for an interval (n = 4; needs 5)"
    )
    # no compensation is worse than every model here: no sentence
    assert uncompensated_wins(pairs) == []
