"""Study statistics against values known in advance: interval coverage at its nominal rate,
exact paired differences, the claims under the one rule."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from rinscal.experiments.study.stats import (
    claims_table,
    method_summary,
    paired_differences,
    uncompensated_wins,
)
from rinscal.experiments.verdict import MIN_N, t_interval


def test_t_interval_covers_a_known_mean_at_its_nominal_rate() -> None:
    """Skewed data (gamma, shape 4, like position errors) with a known mean of 2.0: the 95 %
    Student-t interval over 25 values must cover it about 95 % of the time."""
    rng = np.random.default_rng(42)
    reps, n, true_mean = 400, 25, 2.0
    hits = 0
    for _ in range(reps):
        x = rng.gamma(4.0, true_mean / 4.0, n)
        lo, hi = t_interval(x)
        hits += lo <= true_mean <= hi
    coverage = hits / reps
    # binomial sd at 0.95 over 400 repetitions is 0.011; skew makes t slightly liberal
    assert 0.91 <= coverage <= 0.98, coverage


def test_too_few_or_constant_values() -> None:
    lo, hi = t_interval(np.arange(MIN_N - 1.0))
    assert math.isnan(lo) and math.isnan(hi)
    assert t_interval(np.full(10, 3.0)) == (3.0, 3.0)


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
    assert r["verdict"] == "holds"  # regression better than sectional, in every unit
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


def test_claims_and_verdicts_under_the_one_rule() -> None:
    res = _results()
    pairs = paired_differences(res)
    claims = claims_table(res, pairs)
    m12 = claims[claims["claim"] == "method 2 (regression) better than method 1 (sectional)"]
    m12 = m12.iloc[0]
    # regression = sectional / 2: per unit the difference is −sectional / 2
    d = -np.array([1.0 + u / 10.0 + 0.005 for u in range(8)]) / 2
    assert m12["mean_nmi"] == pytest.approx(d.mean())
    want = stats.t.interval(0.95, 7, loc=d.mean(), scale=stats.sem(d))
    assert (m12["ci_low_nmi"], m12["ci_high_nmi"]) == pytest.approx(want)
    assert m12["verdict"] == "holds" and m12["ours: change"] == "50 % less"
    assert m12["paper"] == "46.30 % less (its best run)"
    m23 = claims[claims["claim"] == "method 3 (BP network) better than method 2 (regression)"]
    assert m23.iloc[0]["verdict"] == "reversed"  # neural is 0.01 nmi worse in every run
    assert m23.iloc[0]["mean_nmi"] == pytest.approx(0.01)
    few = claims_table(_results(n_units=4), paired_differences(_results(n_units=4)))
    assert set(few["verdict"]) == {"not enough runs"}
    assert few["ci_low_nmi"].isna().all()
    # no compensation is worse than every model here: no sentence
    assert uncompensated_wins(pairs) == []
