"""The study report's sentences (``rinscal.report.study_words``): a difference is called a
win or a loss only where its 95 % interval excludes zero, and never with too few units."""

from __future__ import annotations

import pandas as pd

from rinscal.experiments.study.compare import MIN_SAMPLES
from rinscal.report.study_words import code, comparison_lines, short_verdict


def _comp(n: int) -> pd.DataFrame:
    rows = [  # method − reference [nmi]: interval below 0, above 0, across 0
        ("regression", "none", -0.5, -0.1),
        ("neural", "none", 0.1, 0.4),
        ("sectional", "none", -0.2, 0.3),
    ]
    return pd.DataFrame(
        [
            {
                "plant_label": "P",
                "scenario": "qs",
                "n units": n,
                "method": m,
                "reference": r,
                "delta ci low": lo,
                "delta ci high": hi,
            }
            for m, r, lo, hi in rows
        ]
    )


def test_wins_losses_and_unresolved_follow_the_intervals() -> None:
    (line,) = comparison_lines(_comp(8))
    assert line.startswith("P, qs (8 units): ")
    assert "method 2 beats no compensation" in line
    assert "no compensation beats method 3" in line
    assert "no resolved difference from no compensation for method 1" in line


def test_too_few_units_claim_nothing() -> None:
    (line,) = comparison_lines(_comp(MIN_SAMPLES - 1))
    n = MIN_SAMPLES - 1
    assert line.startswith(f"P · qs: not enough units for an interval (n = {n}; needs")
    assert "point estimates; no method is said to beat or lose to another" in line


def test_short_verdicts_use_the_tables_short_names() -> None:
    assert code("regression") == "m2" and code("unknown") == "unknown"
    assert short_verdict(8, -0.3, -0.1, "regression", "poly-t") == "m2 beats cubic (resolved)"
    assert short_verdict(8, 0.1, 0.3, "regression", "none") == "none beats m2 (resolved)"
    assert short_verdict(8, -0.1, 0.3, "neural", "none") == "no resolved difference"
