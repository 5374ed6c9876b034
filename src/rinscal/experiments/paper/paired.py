"""Paired comparisons of navigation variants over the runs of a group.

Every variant of a run navigates the same raw IMU output, so the difference of two variants'
maximum position errors on one run is free of that run's noise, turn-on offsets and
alignment luck: the paired difference. Over the runs of a group its mean gets a Student-t
interval (the runs are independent cold starts); a ratio of medians is given beside it,
because a percent decrease of means is dominated by one heavy-tailed run.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

__all__ = ["CONFIDENCE", "PairedDifference", "interval_text", "paired_difference", "t_interval"]

#: Confidence level of every interval of the reproduction's report.
CONFIDENCE = 0.95


@dataclass(frozen=True)
class PairedDifference:
    """``reference − variant`` over paired runs [nmi]: positive = the variant is better.

    ``lo``/``hi`` are the Student-t interval of the mean (:func:`t_interval`; NaN below
    two runs); ``better`` counts the runs where the variant's error is smaller;
    ``median_ratio`` is median(variant) / median(reference) (below 1 = the variant better).
    """

    n: int
    mean: float
    lo: float
    hi: float
    better: int
    median_ratio: float

    @property
    def verdict(self) -> str:
        """Words: resolved one way, the other, not resolved, or no interval (one run)."""
        if self.n < 2 or not np.isfinite(self.lo):
            return "one run: no interval"
        if self.lo > 0:
            return "better (resolved)"
        if self.hi < 0:
            return "worse (resolved)"
        return "no resolved difference"


def t_interval(
    x: Sequence[float] | np.ndarray, confidence: float = CONFIDENCE, min_n: int = 2
) -> tuple[float, float]:
    """Student-t interval of the mean of the finite values of ``x``: ``m ± t·s/√n``, ``t``
    the ``(1 + confidence)/2`` quantile of Student's t with ``n − 1`` degrees of freedom.
    ``(nan, nan)`` for fewer than ``min_n`` values; ``(m, m)`` when they are all equal."""
    a = np.asarray(x, dtype=float)
    a = a[np.isfinite(a)]
    if a.size < max(min_n, 2):
        return (float("nan"), float("nan"))
    if np.ptp(a) == 0.0:
        return (float(a[0]), float(a[0]))
    m = float(a.mean())
    half = float(stats.t.ppf(0.5 + confidence / 2, a.size - 1)) * float(a.std(ddof=1))
    return (m - half / np.sqrt(a.size), m + half / np.sqrt(a.size))


def paired_difference(
    reference: Sequence[float], variant: Sequence[float], confidence: float = CONFIDENCE
) -> PairedDifference:
    """The paired difference ``reference − variant`` [nmi] with its Student-t interval.

    Parameters
    ----------
    reference, variant : sequences of float [nmi]
        The same runs' maximum position errors (same order).
    confidence : float
        Two-sided level of the interval.
    """
    r = np.asarray(reference, dtype=float)
    v = np.asarray(variant, dtype=float)
    d = r - v
    n = len(d)
    lo, hi = t_interval(d, confidence)
    med_r = float(np.median(r)) if n else float("nan")
    ratio = float(np.median(v)) / med_r if n and med_r > 0 else float("nan")
    return PairedDifference(
        n, float(d.mean()) if n else float("nan"), lo, hi, int((d > 0).sum()), ratio
    )


def interval_text(lo: float, hi: float, like: float, digits: int = 3) -> str:
    """``"[−0.110, 0.030]"`` with the decimals that give ``like`` ``digits`` significant
    digits (at least 3 decimals); empty when there is no interval."""
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return ""
    top = max(abs(lo), abs(hi), abs(like) if np.isfinite(like) else 0.0, 1e-12)
    dec = max(3, digits - 1 - int(np.floor(np.log10(top))))
    return f"[{lo:.{dec}f}, {hi:.{dec}f}]"
