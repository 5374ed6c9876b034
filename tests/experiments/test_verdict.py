"""The one rule (rinscal.experiments.verdict) on pairs whose answers are known in advance:
differences all clearly negative (holds), clearly positive (reversed), straddling zero (no
resolved difference) and too few runs (not enough runs), checked in the verdicts, in the
rows of claims.csv and in the report's words; the interval against scipy and a hand
quantile; percentages beyond ±100 % said as ratios."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from rinscal.experiments.paper.claims import group_means, paired_claims
from rinscal.experiments.verdict import (
    CLAIMS_COLUMNS,
    MIN_N,
    change_words,
    paired,
    t_interval,
    verdict,
)
from rinscal.report.verdict_view import (
    claims_lines,
    verdict_paragraph,
    verdict_table,
    write_claims_csv,
)

#: Six lab runs: method 2 has 0.5 nmi less error than method 1 in every run (± 0.01),
#: method 3 − method 1 straddles zero (±0.1 to ±0.3), so method 3 − method 2 is about
#: +0.5 nmi; three vehicle runs: too few for an interval.
BASE = np.array([1.0, 2.5, 1.4, 3.1, 0.9, 2.0])
E1 = np.array([0.01, -0.01, 0.005, -0.005, 0.0, 0.002])
STRADDLE = np.array([0.3, -0.3, 0.2, -0.2, 0.1, -0.1])


def _maxerr() -> pd.DataFrame:
    lab = pd.DataFrame(
        {"experiment": "lab", "scenario": "quasi-static", "none": BASE + 1.0,
         "poly-t": 3.0 * BASE, "sectional": BASE, "regression": BASE - 0.5 + E1,
         "neural": BASE + STRADDLE}
    )  # fmt: skip
    veh = pd.DataFrame(
        {"experiment": "vehicle", "scenario": "vehicle", "none": [2.0, 3.0, 2.5],
         "poly-t": [2.1, 3.1, 2.6], "sectional": [1.0, 1.5, 1.2],
         "regression": [0.5, 1.0, 0.7], "neural": [0.4, 0.9, 0.6]}
    )  # fmt: skip
    return pd.concat([lab, veh], ignore_index=True)


def test_the_interval_is_students_t_and_needs_the_minimum() -> None:
    x = np.array([0.31, -0.12, 0.45, 0.08, 0.27, 0.19, -0.05])
    lo, hi = t_interval(x)
    assert (lo, hi) == pytest.approx(
        stats.t.interval(0.95, x.size - 1, loc=x.mean(), scale=stats.sem(x)), rel=1e-12
    )
    # by hand: t(0.975, 6) = 2.446912
    assert lo == pytest.approx(x.mean() - 2.446912 * x.std(ddof=1) / math.sqrt(7), rel=1e-6)
    assert MIN_N == 5
    assert all(math.isnan(v) for v in t_interval(x[:4]))
    assert all(math.isfinite(v) for v in t_interval(x[:5]))


def test_verdicts_of_known_pairs() -> None:
    assert paired(BASE, BASE - 0.5 + E1).verdict == "holds"
    assert paired(BASE - 0.5 + E1, BASE + STRADDLE).verdict == "reversed"
    p = paired(BASE, BASE + STRADDLE)
    assert p.verdict == "no resolved difference" and p.mean == pytest.approx(0.0, abs=1e-15)
    assert p.better == 3
    few = paired([1.0, 1.5, 1.2], [0.5, 1.0, 0.7])  # clearly better, but only 3 runs
    assert few.verdict == "not enough runs" and math.isnan(few.lo)
    assert few.words == "not enough runs (n = 3; needs 5)"
    # the rule at its edges: an interval touching zero is not resolved
    assert verdict(5, -0.3, 0.0) == "no resolved difference"
    assert verdict(5, 0.0, 0.3) == "no resolved difference"
    assert verdict(4, -0.3, -0.1) == "not enough runs"


def test_percentages_beyond_100_become_ratios() -> None:
    assert change_words(1.0, 7.5) == "7.5× worse"
    assert change_words(1.0, 2.0) == "100 % more"
    assert change_words(1.0, 1.5) == "50 % more"
    assert change_words(1.0, 0.62) == "38 % less"
    assert change_words(0.0, 1.0) == ""


def test_claims_csv_and_the_reports_words(tmp_path: Path) -> None:
    claims = paired_claims(_maxerr(), "p")
    path = tmp_path / "claims.csv"
    write_claims_csv(path, claims)
    csv = pd.read_csv(path)
    assert list(csv.columns) == list(CLAIMS_COLUMNS)
    assert len(csv) == len(claims)
    # the invariants of the file
    assert ((csv["verdict"] == "holds") == (csv["ci_high_nmi"] < 0)).all()
    assert ((csv["verdict"] == "reversed") == (csv["ci_low_nmi"] > 0)).all()
    assert ((csv["verdict"] == "not enough runs") == (csv["n"] < MIN_N)).all()
    assert set(csv["verdict"]) <= {"holds", "reversed", "no resolved difference", "not enough runs"}
    row = csv.set_index(["group", "claim"])
    qs = "lab quasi-static"
    m21 = row.loc[(qs, "method 2 (regression) better than method 1 (sectional)")]
    assert m21["verdict"] == "holds" and m21["n"] == 6
    assert m21["mean_nmi"] == pytest.approx(-0.5 + E1.mean())
    want = stats.t.interval(0.95, 5, loc=(E1 - 0.5).mean(), scale=stats.sem(E1))
    assert (m21["ci_low_nmi"], m21["ci_high_nmi"]) == pytest.approx(want)
    assert row.loc[(qs, "method 3 (BP network) better than method 2 (regression)"), "verdict"] == (
        "reversed"
    )
    assert row.loc[(qs, "method 3 (BP network) better than method 1 (sectional)"), "verdict"] == (
        "no resolved difference"
    )
    veh = row.loc["vehicle"]
    assert set(veh["verdict"]) == {"not enough runs"} and veh["ci_low_nmi"].isna().all()
    # the words of the report: the paragraph, the verdict table and the console lines
    text = verdict_paragraph(claims, detail=3)
    assert "method 2 better than method 1: holds: −0.50 nmi [−0.51, −0.49]" in text
    assert "method 3 better than method 2: reversed: +0.50 nmi" in text
    assert "method 3 better than method 1: no resolved difference: 0.00 nmi" in text
    assert (
        "On p, vehicle (n = 3 runs): method 2 better than method 1: not enough runs (n = 3; "
        in (text)
    )
    k = csv["verdict"].value_counts()
    assert f"{k['holds']} hold, {k['reversed']} are reversed" in text
    table = verdict_table(group_means(_maxerr(), "p"), claims)
    assert list(table["runs"][:2]) == ["lab + vehicle", ""]  # a group named once
    table = table.assign(runs=table["runs"].replace("", np.nan).ffill()).set_index(
        ["runs", "method"]
    )
    assert table.loc[(qs, "method 2"), "vs method 1"] == "holds (−0.50)"
    assert table.loc[(qs, "method 3"), "vs method 1"] == "no resolved difference (0.00)"
    assert table.loc[(qs, "method 1"), "vs none"] == "holds (−1.00)"
    assert table.loc[(qs, "cubic in T"), "vs none"].startswith("reversed")
    assert table.loc[("vehicle", "method 2"), "vs method 1"] == "not enough runs (−0.50)"
    assert table.loc[("vehicle", "method 2"), "max error [nmi]: mean [95% interval]"] == (
        "0.73 (no interval)"
    )
    lines = claims_lines(claims)
    less = 100 * (0.5 - E1.mean()) / BASE.mean()  # the description of the same pairs
    assert (
        "p · lab quasi-static: method 2 (regression) better than method 1 (sectional) — holds: "
        f"−0.50 nmi [−0.51, −0.49], mean error {less:.0f} % less"
    ) in lines
