"""The reproduction's paired comparisons: Student's t on the paired differences of runs,
checked against scipy and a hand-computed quantile; the sign the study report uses."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from rinscal.experiments.paper.claims import paired_table
from rinscal.experiments.paper.paired import paired_difference, t_interval


def test_t_interval_is_students_t_on_the_mean() -> None:
    x = np.array([0.31, 0.12, 0.45, 0.27, 0.38])
    lo, hi = t_interval(x)
    want = stats.t.interval(0.95, len(x) - 1, loc=x.mean(), scale=stats.sem(x))
    assert (lo, hi) == pytest.approx(want, rel=1e-12)
    # t(0.975, 4) = 2.776445 by hand-table
    h = 2.776445 * x.std(ddof=1) / math.sqrt(5)
    assert lo == pytest.approx(x.mean() - h, rel=1e-6)
    assert all(math.isnan(v) for v in t_interval(x[:1]))
    assert all(math.isnan(v) for v in t_interval(x, min_n=6))


def test_paired_difference_cancels_what_the_runs_share() -> None:
    """Two variants of one run share its noise: a run-to-run spread of ±1 nmi does not hide
    a constant 0.1 nmi advantage when the comparison is paired."""
    run = np.array([0.5, 2.5, 1.0, 3.0, 0.2, 1.7])
    p = paired_difference(run + 0.1, run)
    assert p.mean == pytest.approx(0.1) and p.lo == pytest.approx(0.1)  # no scatter
    assert p.better == 6 and p.verdict == "better (resolved)"
    assert p.median_ratio == pytest.approx(np.median(run) / np.median(run + 0.1))
    noisy = paired_difference(run, run + np.array([0.2, -0.3, 0.1, -0.2, 0.25, -0.1]))
    assert noisy.verdict == "no resolved difference" and noisy.better == 3
    assert paired_difference([1.0], [0.5]).verdict == "one run: no interval"


def test_paired_table_reads_method_minus_reference() -> None:
    rng = np.random.default_rng(3)
    base = rng.uniform(0.5, 2.0, 5)
    maxerr = pd.DataFrame(
        {"experiment": "lab", "scenario": "quasi-static", "none": base,
         "regression": base - 0.3 + rng.normal(0, 0.01, 5), "sectional": base + 1.0}
    )  # fmt: skip
    t = paired_table(maxerr, "none", ["regression", "sectional"]).set_index("variant")
    t = t[t["runs"] == "lab quasi-static"]
    assert t.loc["regression", "Δ mean [nmi]"] == pytest.approx(-0.3, abs=0.02)
    assert t.loc["regression", "verdict"] == "better (resolved)"
    assert t.loc["regression", "better in"] == "5 of 5"
    assert t.loc["sectional", "Δ mean [nmi]"] == pytest.approx(1.0)
    assert t.loc["sectional", "verdict"] == "worse (resolved)"
    lo, hi = (float(v) for v in t.loc["regression", "95% interval [nmi]"].strip("[]").split(","))
    assert lo < -0.3 < hi < 0
