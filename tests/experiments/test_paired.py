"""The reproduction's paired comparisons under the one rule: the sign the study report uses
(method − reference), pairing that cancels what the runs share, and the claims per group."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from rinscal.experiments.paper.claims import CLAIM_PAIRS, paired_claims, paired_table
from rinscal.experiments.verdict import paired


def test_paired_difference_cancels_what_the_runs_share() -> None:
    """Two variants of one run share its noise: a run-to-run spread of ±1 nmi does not hide
    a constant 0.1 nmi advantage when the comparison is paired."""
    run = np.array([0.5, 2.5, 1.0, 3.0, 0.2, 1.7])
    p = paired(run + 0.1, run)  # the method has 0.1 nmi less error than the reference
    assert p.mean == pytest.approx(-0.1) and p.hi == pytest.approx(-0.1)  # no scatter
    assert p.better == 6 and p.verdict == "holds"
    # unpaired, the same 0.1 nmi would drown in the ±1 nmi spread of the runs
    assert stats.ttest_ind(run, run + 0.1).pvalue > 0.5
    noisy = paired(run, run + np.array([0.2, -0.3, 0.1, -0.2, 0.25, -0.1]))
    assert noisy.verdict == "no resolved difference" and noisy.better == 3
    assert paired([1.0], [0.5]).words == "not enough runs (n = 1; needs 5)"


def test_paired_table_reads_method_minus_reference() -> None:
    rng = np.random.default_rng(3)
    base = rng.uniform(0.5, 2.0, 5)
    maxerr = pd.DataFrame(
        {"experiment": "lab", "scenario": "quasi-static", "none": base,
         "regression": base - 0.3 + rng.normal(0, 0.01, 5), "sectional": 3.0 * base}
    )  # fmt: skip
    t = paired_table(maxerr, "none", ["regression", "sectional"]).set_index("variant")
    t = t[t["runs"] == "lab quasi-static"]
    assert t.loc["regression", "Δ mean [nmi]"] == pytest.approx(-0.3, abs=0.02)
    assert t.loc["regression", "verdict"] == "holds"
    assert t.loc["regression", "better in"] == "5 of 5"
    assert t.loc["sectional", "Δ mean [nmi]"] == pytest.approx(2.0 * base.mean())
    assert t.loc["sectional", "verdict"] == "reversed"
    # +200 % is said as a ratio; −30 % as a percentage
    assert t.loc["sectional", "mean error"] == "3.0× worse"
    want = 100 * 0.3 / base.mean()
    assert t.loc["regression", "mean error"] in {f"{want + e:.0f} % less" for e in (-1, 0, 1)}
    text = t.loc["regression", "95% interval [nmi]"].replace("−", "-")
    lo, hi = (float(v) for v in text.strip("[]").split(","))
    assert lo < -0.3 < hi < 0


def test_paired_claims_cover_the_papers_comparisons_in_every_group() -> None:
    rng = np.random.default_rng(5)
    n = 6
    base = rng.uniform(0.5, 2.0, n)
    maxerr = pd.DataFrame(
        {"experiment": "lab", "scenario": "swing", "none": base, "poly-t": base + 0.05,
         "sectional": base + 0.2, "regression": base - 0.1 + rng.normal(0, 0.01, n),
         "neural": base + 0.4 + rng.normal(0, 0.5, n)}
    )  # fmt: skip
    c = paired_claims(maxerr, "p")
    assert set(c["group"]) == {"lab + vehicle", "lab swing"}
    assert len(c) == 2 * len(CLAIM_PAIRS)
    c = c[c["group"] == "lab swing"].set_index(["method", "reference"])
    assert c.loc[("regression", "sectional"), "verdict"] == "holds"
    assert c.loc[("regression", "sectional"), "mean_nmi"] == pytest.approx(-0.3, abs=0.02)
    assert c.loc[("sectional", "none"), "verdict"] == "reversed"
    assert c.loc[("regression", "sectional"), "claim"] == (
        "method 2 (regression) better than method 1 (sectional)"
    )
