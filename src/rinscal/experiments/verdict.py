"""The one rule for every verdict of the reproduction, the study, the CLI and the README.

A claim reads "method better than reference". Its test is the **paired difference** of the
maximum horizontal position error, ``d = e_method − e_reference`` [nmi], taken per run (the
reproduction: both navigate the same raw IMU output) or per unit (the study: averaged over
the unit's cold starts first, since those share its calibration). Over the ``n`` runs or
units the mean of ``d`` gets a two-sided 95 % **Student-t interval** ``m ± t·s/√n``
(:func:`t_interval`), given only from :data:`MIN_N` pairs on. The verdict (:func:`verdict`)
is exactly one of

* ``holds``: the interval lies below zero (the method has less error);
* ``reversed``: the interval lies above zero (the method has more error);
* ``no resolved difference``: the interval contains zero;
* ``not enough runs``: fewer than :data:`MIN_N` pairs, so no interval
  (in words: "not enough runs (n = 3; needs 5)", :func:`too_few`).

Percentages and ratios (:func:`change_words`) describe the same pairs' means; they are never
the test. A percentage that would exceed ±100 % is said as a ratio ("7.5× worse").
Claims in other units (held-out residuals [µg], coefficient recovery) say their own unit
and are not verdicts of this rule.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

__all__ = [
    "CLAIMS_COLUMNS",
    "CONFIDENCE",
    "HOLDS",
    "MIN_N",
    "REVERSED",
    "RULE",
    "TOO_FEW",
    "UNRESOLVED",
    "VERDICTS",
    "Paired",
    "change_words",
    "claim_row",
    "interval_text",
    "paired",
    "t_interval",
    "too_few",
    "verdict",
]

#: Two-sided confidence level of every interval.
CONFIDENCE = 0.95
#: Fewest pairs (runs or units) an interval and a verdict are given for.
MIN_N = 5
HOLDS = "holds"
REVERSED = "reversed"
UNRESOLVED = "no resolved difference"
TOO_FEW = "not enough runs"
#: Every verdict, in this order.
VERDICTS = (HOLDS, REVERSED, UNRESOLVED, TOO_FEW)
#: Columns of ``claims.csv``, in order (nmi: the paired difference method − reference).
CLAIMS_COLUMNS = (
    "claim",
    "plant",
    "group",
    "n",
    "mean_nmi",
    "ci_low_nmi",
    "ci_high_nmi",
    "verdict",
)
#: The rule in one sentence, for reports and help texts.
RULE = (
    "A claim 'method better than reference' is tested on the paired difference of the "
    "maximum position error, method − reference [nmi], per run (per unit in a study): it "
    f"holds when the {CONFIDENCE:.0%} Student-t interval of the mean difference lies below "
    "zero, is reversed when it lies above, shows no resolved difference when it contains "
    f"zero, and below {MIN_N} runs (units) there is no interval: not enough runs. "
    "Percentages and ratios only describe the same pairs."
)


def t_interval(
    x: Sequence[float] | np.ndarray, confidence: float = CONFIDENCE, min_n: int = MIN_N
) -> tuple[float, float]:
    """Student-t interval of the mean of the finite values of ``x`` [their unit]:
    ``m ± t·s/√n``, ``t`` the ``(1 + confidence)/2`` quantile of Student's t with ``n − 1``
    degrees of freedom. ``(nan, nan)`` below ``min_n`` values (at least 2); ``(m, m)`` when
    they are all equal."""
    a = np.asarray(x, dtype=float)
    a = a[np.isfinite(a)]
    if a.size < max(min_n, 2):
        return (math.nan, math.nan)
    if np.ptp(a) == 0.0:
        return (float(a[0]), float(a[0]))
    m = float(a.mean())
    half = float(stats.t.ppf(0.5 + confidence / 2, a.size - 1)) * float(a.std(ddof=1))
    return (m - half / math.sqrt(a.size), m + half / math.sqrt(a.size))


def verdict(n: int, lo: float, hi: float, min_n: int = MIN_N) -> str:
    """The verdict on "method better than reference" from the interval ``[lo, hi]`` [nmi]
    of the mean of method − reference over ``n`` pairs (one of :data:`VERDICTS`)."""
    if n < min_n or not (math.isfinite(lo) and math.isfinite(hi)):
        return TOO_FEW
    if hi < 0:
        return HOLDS
    if lo > 0:
        return REVERSED
    return UNRESOLVED


def too_few(n: int, what: str = "", min_n: int = MIN_N) -> str:
    """``"not enough runs (n = 3; needs 5)"``; ``what`` names the pairs (``"units"``)."""
    unit = f" {what}" if what else ""
    return f"{TOO_FEW} (n = {n}{unit}; needs {min_n})"


@dataclass(frozen=True)
class Paired:
    """A paired comparison, method − reference [nmi] over ``n`` runs or units.

    ``mean``, ``lo``, ``hi``: the mean difference and its Student-t interval (NaN below
    :data:`MIN_N`); ``better``: pairs where the method has less error (a count);
    ``mean_reference``, ``mean_method``: the two means [nmi].
    """

    n: int
    mean: float
    lo: float
    hi: float
    better: int
    mean_reference: float
    mean_method: float

    @property
    def verdict(self) -> str:
        """One of :data:`VERDICTS` (:func:`verdict`)."""
        return verdict(self.n, self.lo, self.hi)

    @property
    def words(self) -> str:
        """The verdict, with why where there is too little data."""
        v = self.verdict
        return too_few(self.n) if v == TOO_FEW else v


def paired(
    reference: Sequence[float] | np.ndarray,
    method: Sequence[float] | np.ndarray,
    confidence: float = CONFIDENCE,
) -> Paired:
    """The paired difference ``method − reference`` [nmi] over the pairs where both are
    finite (same runs or units, same order)."""
    r = np.asarray(reference, dtype=float)
    m = np.asarray(method, dtype=float)
    ok = np.isfinite(r) & np.isfinite(m)
    r, m = r[ok], m[ok]
    d = m - r
    n = int(d.size)
    lo, hi = t_interval(d, confidence)
    nan = math.nan
    return Paired(
        n=n,
        mean=float(d.mean()) if n else nan,
        lo=lo,
        hi=hi,
        better=int((d < 0).sum()),
        mean_reference=float(r.mean()) if n else nan,
        mean_method=float(m.mean()) if n else nan,
    )


def change_words(mean_reference: float, mean_method: float) -> str:
    """How the method's mean error compares with the reference's, as a description:
    ``"38 % less"``, ``"12 % more"``, or a ratio where a percentage would exceed ±100 %
    (``"7.5× worse"``); empty where the reference mean is not positive."""
    a, b = mean_reference, mean_method
    if not (math.isfinite(a) and math.isfinite(b)) or a <= 0:
        return ""
    pct = 100.0 * (b - a) / a
    if pct > 100.0:
        return f"{b / a:.1f}× worse"
    if pct < 0:
        return f"{-pct:.0f} % less"
    return f"{pct:.0f} % more"


def claim_row(claim: str, plant: str, group: str, p: Paired) -> dict[str, Any]:
    """One row of ``claims.csv`` (:data:`CLAIMS_COLUMNS`) for a paired comparison."""
    values = (claim, plant, group, p.n, p.mean, p.lo, p.hi, p.verdict)
    return dict(zip(CLAIMS_COLUMNS, values, strict=True))


def interval_text(lo: float, hi: float, like: float, digits: int = 3) -> str:
    """``"[−0.110, 0.030]"`` with the decimals that give ``like`` ``digits`` significant
    digits (at least 3 decimals); empty when there is no interval."""
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return ""
    top = max(abs(lo), abs(hi), abs(like) if math.isfinite(like) else 0.0, 1e-12)
    dec = max(3, digits - 1 - int(np.floor(np.log10(top))))
    return f"[{lo:.{dec}f}, {hi:.{dec}f}]".replace("-", "−")
