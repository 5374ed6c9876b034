"""Comparisons that decide: every method against a reference, paired, in nautical miles.

A comparison of method ``m`` with a reference ``r`` (no compensation, the cubic in ``T``,
the oracle, method 2 without its ``ΔT`` terms) is built in three steps, because the units
are the independent draws and a unit's cold starts share its calibration:

1. **pair within a run**: ``d = e_m − e_r`` on the same raw output of one cold start
   (``e`` the maximum horizontal position error [nmi]; negative: ``m`` has less error);
2. **average within a unit**: the mean of ``d`` over the unit's starts;
3. **interval over units**: the mean of the unit values with its Student-t interval
   (:func:`t_interval`, 95 %), given only from :data:`MIN_SAMPLES` units on.

The difference is in nmi, not a percentage of heavy-tailed means (a method that sometimes
diverges makes a percent decrease of the mean meaningless). Where a ratio is wanted it is the
ratio of the medians over units (:func:`median_ratio`), with a paired percentile bootstrap
interval. The verdict (:func:`decide`) is one of four, never "within noise": the reference
or the method wins with an interval that excludes zero, "no resolved difference", or "not
enough units for an interval".

The gradient ablation (:func:`design_table`) adds, per unit, how separable ``Ṫ`` and ``ΔT``
were in its soak design: their correlation and the condition number of the standardised
design ``[T, Ṫ, ΔT]`` (columns recorded by the calibration task).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from rinscal.experiments.paper.config import LABELS
from rinscal.experiments.paper.paired import CONFIDENCE
from rinscal.experiments.paper.paired import t_interval as paired_t_interval

__all__ = [
    "CONFIDENCE",
    "DESIGN_COLUMNS",
    "MIN_SAMPLES",
    "NO_DT_VARIANT",
    "decide",
    "design_table",
    "fmt_interval",
    "median_ratio",
    "not_enough",
    "paired_against",
    "t_interval",
]

#: Fewest units an interval is given for: below it no interval is computed (NaN), and the
#: verdict says "not enough units for an interval".
MIN_SAMPLES = 5
#: Method 2 with its ``ΔT`` terms dropped (regression on ``T`` and ``Ṫ`` only).
NO_DT_VARIANT = "regression-no-dT"
#: Per-unit soak-design columns of the results (written by the calibration task): the
#: correlation of ``Ṫ`` and ``ΔT`` and the condition number of the standardised design
#: ``[T, Ṫ, ΔT]``, both over the unit's soak runs (horizontal accelerometers, worse of x, y).
DESIGN_COLUMNS = ("soak_rate_grad_corr", "soak_design_cond")
#: Bootstrap resamples of a ratio-of-medians interval.
_N_RESAMPLES = 4999


def t_interval(
    x: Sequence[float] | np.ndarray, confidence: float = CONFIDENCE
) -> tuple[float, float]:
    """Student-t interval of the mean of the finite values of ``x``: ``m ± t·s/√n`` with
    ``t`` the ``(1 + confidence)/2`` quantile of Student's t with ``n − 1`` degrees of
    freedom. NaN for fewer than :data:`MIN_SAMPLES` values; ``(m, m)`` for no spread."""
    return paired_t_interval(x, confidence, min_n=MIN_SAMPLES)


def _median_ratio(a: np.ndarray, b: np.ndarray, axis: int = -1) -> np.ndarray:
    return np.median(b, axis=axis) / np.median(a, axis=axis)


def median_ratio(
    a: Sequence[float] | np.ndarray,
    b: Sequence[float] | np.ndarray,
    confidence: float = CONFIDENCE,
    seed: int = 0,
) -> tuple[float, float, float]:
    """``median(b) / median(a)`` over paired values (units) with a paired percentile
    bootstrap interval; the interval is NaN below :data:`MIN_SAMPLES` pairs."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    ok = np.isfinite(a) & np.isfinite(b)
    a, b = a[ok], b[ok]
    if a.size == 0 or np.median(a) == 0.0:
        return (math.nan, math.nan, math.nan)
    r = float(_median_ratio(a, b))
    if a.size < MIN_SAMPLES:
        return (r, math.nan, math.nan)
    if np.ptp(a) == 0.0 and np.ptp(b) == 0.0:
        return (r, r, r)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ci = stats.bootstrap(
            (a, b),
            _median_ratio,
            paired=True,
            vectorized=True,
            confidence_level=confidence,
            n_resamples=_N_RESAMPLES,
            method="percentile",
            rng=np.random.default_rng(seed),
        ).confidence_interval
    return (r, float(ci.low), float(ci.high))


def not_enough(n: int) -> str:
    """``"not enough units for an interval (n = 3; needs 5)"``."""
    return f"not enough units for an interval (n = {n}; needs {MIN_SAMPLES})"


def decide(n: int, lo: float, hi: float, reference: str, method: str) -> str:
    """The verdict on ``method − reference`` [nmi] from its 95 % interval ``[lo, hi]`` over
    ``n`` units, in words (``reference`` and ``method`` are the names to print).

    ``"<method> beats <reference> (resolved)"`` when the interval lies below zero,
    ``"<reference> beats <method> (resolved)"`` when above, ``"no resolved difference"``
    when it contains zero, :func:`not_enough` below :data:`MIN_SAMPLES` units.
    """
    if n < MIN_SAMPLES or not (math.isfinite(lo) and math.isfinite(hi)):
        return not_enough(n)
    if hi < 0:
        return f"{method} beats {reference} (resolved)"
    if lo > 0:
        return f"{reference} beats {method} (resolved)"
    return "no resolved difference"


def fmt_interval(lo: float, hi: float, nd: int) -> str:
    """``"[−0.11, −0.03]"`` with ``nd`` decimals (a true minus sign); ``""`` if undefined."""
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return ""
    return f"[{lo:.{nd}f}, {hi:.{nd}f}]".replace("-", "−")


def _label(v: str) -> str:
    return {"none": "no compensation"}.get(v, LABELS.get(v, v))


def paired_against(
    results: pd.DataFrame,
    references: Sequence[str] = ("none", "poly-t"),
    methods: Sequence[str] | None = None,
    metric: str = "max_error_nmi",
) -> pd.DataFrame:
    """Every method against each reference, paired per run, per plant and scenario.

    Parameters
    ----------
    results : DataFrame
        The study's results (one row per run and variant).
    references : sequence of str
        Reference variants (``none``, ``poly-t``, ``true``, ...).
    methods : sequence of str, optional
        Variants compared with each reference; default every variant in the results but the
        oracle (a reference is compared with the references after it: the cubic in T
        against no compensation, not the mirror).
    metric : str
        The per-run error compared [nmi].

    Returns
    -------
    DataFrame
        Per plant, scenario, reference and method: ``n units``, ``n runs``, ``mean
        reference`` and ``mean method`` [nmi] (over units), ``delta`` = mean over units of
        (method − reference) [nmi] with ``delta ci low/high`` (Student-t over units),
        ``median ratio`` (median over units of the method's unit means over the reference's)
        with ``ratio ci low/high``, ``units method better`` (a count, of ``n units``),
        ``runs method better`` (a count, of ``n runs``),
        ``verdict`` (:func:`decide`).
    """
    df = results[np.isfinite(results[metric].to_numpy(float))]
    runs = df.pivot_table(
        index=["plant", "plant_label", "scenario", "unit", "start"],
        columns="variant",
        values=metric,
        aggfunc="first",
        observed=True,
    )
    order = ["none", "poly-t", "sectional", "regression", NO_DT_VARIANT, "neural"]
    have = sorted(runs.columns, key=lambda v: (order.index(v) if v in order else len(order), v))
    if methods is None:
        methods = [v for v in have if v != "true"]
    align = (
        results.drop_duplicates(["plant", "scenario"]).set_index(["plant", "scenario"])[
            "align_start_s"
        ]
        if "align_start_s" in results
        else None
    )
    rows: list[dict[str, Any]] = []
    for (plant, label, scen), g in runs.groupby(level=[0, 1, 2], sort=False):
        for ref in references:
            if ref not in have:
                continue
            for m in methods:
                if m not in have or m == ref:
                    continue
                if m in references and references.index(m) < references.index(ref):
                    continue  # the mirror of a comparison already made
                pair = g[[ref, m]].dropna()
                if pair.empty:
                    continue
                unit = pair.groupby(level="unit").mean()
                d = (unit[m] - unit[ref]).to_numpy(float)
                n = int(d.size)
                lo, hi = t_interval(d)
                ratio, rlo, rhi = median_ratio(unit[ref].to_numpy(), unit[m].to_numpy())
                rows.append(
                    {
                        "plant": plant,
                        "plant_label": label,
                        "scenario": scen,
                        "align_start_s": float(align.get((plant, scen), math.nan))
                        if align is not None
                        else math.nan,
                        "reference": ref,
                        "method": m,
                        "comparison": f"{_label(m)} − {_label(ref)}",
                        "metric": metric,
                        "n units": n,
                        "n runs": len(pair),
                        "mean reference": float(unit[ref].mean()),
                        "mean method": float(unit[m].mean()),
                        "delta": float(d.mean()),
                        "delta ci low": lo,
                        "delta ci high": hi,
                        "median ratio": ratio,
                        "ratio ci low": rlo,
                        "ratio ci high": rhi,
                        "units method better": int((d < 0).sum()),
                        "runs method better": int((pair[m] < pair[ref]).sum()),
                        "verdict": decide(n, lo, hi, _label(ref), _label(m)),
                    }
                )
    return pd.DataFrame(rows)


def design_table(results: pd.DataFrame) -> pd.DataFrame:
    """Per plant and unit, how separable ``Ṫ`` and ``ΔT`` were in its soak design
    (:data:`DESIGN_COLUMNS`; empty when the results predate them)."""
    cols = [c for c in DESIGN_COLUMNS if c in results]
    if len(cols) < len(DESIGN_COLUMNS):
        return pd.DataFrame()
    d = results.drop_duplicates(["plant", "unit"])[["plant", "plant_label", "unit", *cols]]
    d = d.dropna(subset=cols)
    return d.sort_values(["plant", "unit"]).reset_index(drop=True)
