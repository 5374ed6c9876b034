"""Comparisons that decide: every method against a reference, paired, in nautical miles.

A comparison of method ``m`` with a reference ``r`` (no compensation, the cubic in ``T``,
the oracle, method 2 without its ``ΔT`` terms) is built in three steps, because the units
are the independent draws and a unit's cold starts share its calibration:

1. **pair within a run**: ``d = e_m − e_r`` on the same raw output of one cold start
   (``e`` the maximum horizontal position error [nmi]; negative: ``m`` has less error);
2. **average within a unit**: the mean of ``d`` over the unit's starts;
3. **interval over units**: the mean of the unit values with its Student-t interval
   (95 %), given only from :data:`~rinscal.experiments.verdict.MIN_N` units on.

The difference is in nmi, not a percentage of heavy-tailed means (a method that sometimes
diverges makes a percent decrease of the mean meaningless). Where a ratio is wanted it is the
ratio of the medians over units (:func:`median_ratio`), with a paired percentile bootstrap
interval. The verdict on "method better than reference" is the one rule of
:mod:`rinscal.experiments.verdict`: ``holds``, ``reversed``, ``no resolved difference`` or
``not enough runs``.

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

from rinscal.experiments.paper.claims import CLAIM_PAIRS, claim_name
from rinscal.experiments.paper.config import LABELS
from rinscal.experiments.verdict import CLAIMS_COLUMNS, CONFIDENCE, MIN_N, paired, t_interval

__all__ = [
    "CONFIDENCE",
    "DESIGN_COLUMNS",
    "FIELD_VARIANT",
    "MIN_N",
    "NO_DT_VARIANT",
    "STUDY_CLAIM_PAIRS",
    "design_table",
    "fmt_interval",
    "mean_ratio",
    "median_ratio",
    "paired_against",
    "study_claims",
]

#: Method 2 with its ``ΔT`` terms dropped (regression on ``T`` and ``Ṫ`` only).
NO_DT_VARIANT = "regression-no-dT"
#: The thermal model calibrated without a chamber from the unit's own parked cold starts
#: (:func:`rinscal.nav.fieldcal.calibrate_field`).
FIELD_VARIANT = "field"
#: The claims of a study: the reproduction's (:data:`CLAIM_PAIRS`), then the field
#: calibration against the chamber's method 2 and against no compensation (pairs whose
#: variants a study did not run are skipped).
STUDY_CLAIM_PAIRS = (*CLAIM_PAIRS, (FIELD_VARIANT, "regression"), (FIELD_VARIANT, "none"))
#: Per-unit soak-design columns of the results (written by the calibration task): the
#: correlation of ``Ṫ`` and ``ΔT`` and the condition number of the standardised design
#: ``[T, Ṫ, ΔT]``, both over the unit's soak runs (horizontal accelerometers, worse of x, y).
DESIGN_COLUMNS = ("soak_rate_grad_corr", "soak_design_cond")
#: Bootstrap resamples of a ratio-of-medians interval.
_N_RESAMPLES = 4999


def _median_ratio(a: np.ndarray, b: np.ndarray, axis: int = -1) -> np.ndarray:
    return np.median(b, axis=axis) / np.median(a, axis=axis)


def median_ratio(
    a: Sequence[float] | np.ndarray,
    b: Sequence[float] | np.ndarray,
    confidence: float = CONFIDENCE,
    seed: int = 0,
) -> tuple[float, float, float]:
    """``median(b) / median(a)`` over paired values (units) with a paired percentile
    bootstrap interval (a description, not a test); the interval is NaN below
    :data:`MIN_N` pairs."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    ok = np.isfinite(a) & np.isfinite(b)
    a, b = a[ok], b[ok]
    if a.size == 0 or np.median(a) == 0.0:
        return (math.nan, math.nan, math.nan)
    r = float(_median_ratio(a, b))
    if a.size < MIN_N:
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


def mean_ratio(
    reference: pd.Series, method: pd.Series, confidence: float = CONFIDENCE
) -> tuple[float, float, float]:
    """The paired ratio ``e_method / e_reference`` of each run (same raw output), averaged
    over a unit's runs, then over units, with the Student-t interval over units
    (:func:`rinscal.experiments.verdict.t_interval`; NaN below :data:`MIN_N` units).

    ``reference`` and ``method`` [nmi] are indexed by run with a ``unit`` level; runs where
    the reference's error is not positive or either is not finite are left out. Returns
    ``(mean, low, high)`` [dimensionless].
    """
    r = method.to_numpy(float) / reference.to_numpy(float)
    ok = np.isfinite(r) & (reference.to_numpy(float) > 0)
    if not ok.any():
        return (math.nan, math.nan, math.nan)
    per_unit = pd.Series(r[ok], index=reference.index[ok]).groupby(level="unit").mean()
    lo, hi = t_interval(per_unit.to_numpy(), confidence)
    return (float(per_unit.mean()), lo, hi)


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
        with ``ratio ci low/high``, ``mean ratio`` (:func:`mean_ratio`) with ``mean ratio ci
        low/high``, ``units method better`` (a count, of ``n units``),
        ``runs method better`` (a count, of ``n runs``),
        ``verdict`` on "method better than reference"
        (:func:`rinscal.experiments.verdict.verdict`).
    """
    df = results[np.isfinite(results[metric].to_numpy(float))]
    runs = df.pivot_table(
        index=["plant", "plant_label", "scenario", "unit", "start"],
        columns="variant",
        values=metric,
        aggfunc="first",
        observed=True,
    )
    order = ["none", "poly-t", "sectional", "regression", NO_DT_VARIANT, "neural", FIELD_VARIANT]
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
                p = paired(unit[ref].to_numpy(float), unit[m].to_numpy(float))
                ratio, rlo, rhi = median_ratio(unit[ref].to_numpy(), unit[m].to_numpy())
                mr, mlo, mhi = mean_ratio(pair[ref], pair[m])
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
                        "n units": p.n,
                        "n runs": len(pair),
                        "mean reference": float(unit[ref].mean()),
                        "mean method": float(unit[m].mean()),
                        "delta": p.mean,
                        "delta ci low": p.lo,
                        "delta ci high": p.hi,
                        "median ratio": ratio,
                        "ratio ci low": rlo,
                        "ratio ci high": rhi,
                        "mean ratio": mr,
                        "mean ratio ci low": mlo,
                        "mean ratio ci high": mhi,
                        "units method better": p.better,
                        "runs method better": int((pair[m] < pair[ref]).sum()),
                        "verdict": p.verdict,
                    }
                )
    return pd.DataFrame(rows)


def study_claims(
    results: pd.DataFrame, pairs: Sequence[tuple[str, str]] = STUDY_CLAIM_PAIRS
) -> pd.DataFrame:
    """The claims of ``claims.csv`` for a study: each ``(method, reference)`` of ``pairs``
    (default :data:`STUDY_CLAIM_PAIRS`: the reproduction's and the field calibration's) per
    plant (its label) and scenario (the group), paired per unit (:func:`paired_against`).

    Returns
    -------
    DataFrame
        :data:`rinscal.experiments.verdict.CLAIMS_COLUMNS` (``n``: units; ``mean_nmi`` and
        its interval: method − reference [nmi]), then ``method``, ``reference``,
        ``mean_method_nmi``, ``mean_reference_nmi`` and ``better`` (units where the method
        has less error).
    """
    refs = list(dict.fromkeys(r for _, r in pairs))
    parts = [paired_against(results, (ref,), [m for m, r in pairs if r == ref]) for ref in refs]
    comp = pd.concat([p for p in parts if not p.empty], ignore_index=True) if parts else None
    extra = ["method", "reference", "mean_method_nmi", "mean_reference_nmi", "better"]
    if comp is None or comp.empty:
        return pd.DataFrame(columns=[*CLAIMS_COLUMNS, *extra])
    order = {pair: i for i, pair in enumerate(pairs)}
    comp = comp[[(m, r) in order for m, r in zip(comp["method"], comp["reference"], strict=True)]]
    rank = [order[(m, r)] for m, r in zip(comp["method"], comp["reference"], strict=True)]
    plant_rank = {p: i for i, p in enumerate(dict.fromkeys(results["plant"]))}
    scen_rank = {s: i for i, s in enumerate(dict.fromkeys(results["scenario"]))}
    comp = comp.assign(
        _p=comp["plant"].map(plant_rank), _s=comp["scenario"].map(scen_rank), _c=rank
    ).sort_values(["_p", "_s", "_c"], kind="stable")
    return pd.DataFrame(
        {
            "claim": [
                claim_name(m, r) for m, r in zip(comp["method"], comp["reference"], strict=True)
            ],
            "plant": comp["plant_label"].to_numpy(),
            "group": comp["scenario"].to_numpy(),
            "n": comp["n units"].to_numpy(),
            "mean_nmi": comp["delta"].to_numpy(),
            "ci_low_nmi": comp["delta ci low"].to_numpy(),
            "ci_high_nmi": comp["delta ci high"].to_numpy(),
            "verdict": comp["verdict"].to_numpy(),
            "method": comp["method"].to_numpy(),
            "reference": comp["reference"].to_numpy(),
            "mean_method_nmi": comp["mean method"].to_numpy(),
            "mean_reference_nmi": comp["mean reference"].to_numpy(),
            "better": comp["units method better"].to_numpy(),
        }
    )


def design_table(results: pd.DataFrame) -> pd.DataFrame:
    """Per plant and unit, how separable ``Ṫ`` and ``ΔT`` were in its soak design
    (:data:`DESIGN_COLUMNS`; empty when the results predate them)."""
    cols = [c for c in DESIGN_COLUMNS if c in results]
    if len(cols) < len(DESIGN_COLUMNS):
        return pd.DataFrame()
    d = results.drop_duplicates(["plant", "unit"])[["plant", "plant_label", "unit", *cols]]
    d = d.dropna(subset=cols)
    return d.sort_values(["plant", "unit"]).reset_index(drop=True)
