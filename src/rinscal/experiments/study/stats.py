"""Statistics of a study: means with bootstrap confidence intervals, paired differences,
the paper's claims with a verdict each, the sensitivity map.

The unit of analysis is the simulated IMU unit. Where a scenario has several cold starts per
unit (the lab's five temperatures), they are averaged per unit first; the intervals are
bootstrap intervals over units (:func:`scipy.stats.bootstrap`, BCa, 95 %), so that starts of
the same unit, which share its calibration, are not counted as independent. Comparisons
between methods are paired: both navigated on the same raw data of the same unit and start;
a paired difference in nmi gets a Student-t interval over units
(:func:`rinscal.experiments.study.compare.t_interval`). Below :data:`MIN_SAMPLES` units no
interval is computed and every verdict says "not enough units for an interval".
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from rinscal.experiments.paper.config import LABELS, PAPER
from rinscal.experiments.paper.navigation import RESIDUAL_COLUMNS
from rinscal.experiments.study.compare import (
    CONFIDENCE,
    MIN_SAMPLES,
    NO_DT_VARIANT,
    decide,
    not_enough,
    t_interval,
)

#: Bootstrap resamples per interval.
N_RESAMPLES = 4999
#: The metrics summarised, with their unit: per run maximum horizontal position error,
#: its thermal part (variant minus oracle), |heading error| at the start of navigation, and
#: the model's held-out thermal residual on the cold start itself
#: (:func:`rinscal.experiments.paper.navigation.thermal_residual`).
METRICS = {
    "max_error_nmi": "nmi",
    "thermal_part_nmi": "nmi",
    "abs_heading_error_arcsec": "arcsec",
    "accel_residual_pct": "%",
    "accel_residual_ug": "µg",
    "gyro_residual_dph": "°/h",
}
#: Methods compared pairwise, in order: each pair (a, b) with a before b.
PAIR_ORDER = ("none", "poly-t", "sectional", "regression", NO_DT_VARIANT, "neural")


def _interval(
    data: tuple[np.ndarray, ...],
    statistic: Callable[..., Any],
    confidence: float,
    n_resamples: int,
    seed: int,
    paired: bool,
) -> tuple[float, float]:
    """:func:`scipy.stats.bootstrap` interval, BCa, or percentile where BCa is undefined."""
    out = (math.nan, math.nan)
    for method in ("BCa", "percentile"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = stats.bootstrap(
                data,
                statistic,
                paired=paired,
                vectorized=True,
                confidence_level=confidence,
                n_resamples=n_resamples,
                method=method,
                rng=np.random.default_rng(seed),
            )
        out = (float(r.confidence_interval.low), float(r.confidence_interval.high))
        if all(map(math.isfinite, out)):
            break
    return out


def bootstrap_ci(
    x: Sequence[float] | np.ndarray,
    statistic: Callable[..., Any] = np.mean,
    confidence: float = CONFIDENCE,
    n_resamples: int = N_RESAMPLES,
    seed: int = 0,
) -> tuple[float, float]:
    """BCa bootstrap interval of ``statistic`` (vectorised, with an ``axis`` keyword) of the
    finite values of ``x``. NaN for fewer than :data:`MIN_SAMPLES` values; the value itself
    when all values are equal (no spread to resample)."""
    v = np.asarray(x, dtype=float)
    v = v[np.isfinite(v)]
    if v.size < MIN_SAMPLES:
        return (math.nan, math.nan)
    if np.ptp(v) == 0.0:
        s = float(statistic(v, axis=-1))
        return (s, s)
    return _interval((v,), statistic, confidence, n_resamples, seed, paired=False)


def _decrease(a: np.ndarray, b: np.ndarray, axis: int = -1) -> np.ndarray:
    """Decrease of the mean from ``a`` to ``b`` [%]: ``100 (mean a − mean b) / mean a``."""
    ma = np.mean(a, axis=axis)
    return 100.0 * (ma - np.mean(b, axis=axis)) / ma


def paired_decrease_ci(
    a: np.ndarray, b: np.ndarray, confidence: float = CONFIDENCE, seed: int = 0
) -> tuple[float, float]:
    """Bootstrap interval of the decrease of the mean from ``a`` to ``b`` [%], resampling
    the pairs ``(a_i, b_i)`` together (BCa, falling back to percentile)."""
    ok = np.isfinite(a) & np.isfinite(b)
    a, b = np.asarray(a, float)[ok], np.asarray(b, float)[ok]
    if a.size < MIN_SAMPLES:
        return (math.nan, math.nan)
    if np.ptp(a - b) == 0.0 and np.ptp(a) == 0.0:
        d = float(_decrease(a, b))
        return (d, d)
    return _interval((a, b), _decrease, confidence, N_RESAMPLES, seed, paired=True)


def prepare(results: pd.DataFrame) -> pd.DataFrame:
    """The results with ``abs_heading_error_arcsec`` added."""
    df = results.copy()
    df["abs_heading_error_arcsec"] = df["heading_error_arcsec"].abs()
    return df


def _unit_table(df: pd.DataFrame, metric: str) -> pd.DataFrame:
    """Per plant, scenario and unit (rows) and variant (columns): the metric averaged over
    the unit's starts."""
    return df.pivot_table(
        index=["plant", "plant_label", "scenario", "unit"],
        columns="variant",
        values=metric,
        aggfunc="mean",
        observed=True,
    )


def _run_table(df: pd.DataFrame, metric: str) -> pd.DataFrame:
    return df.pivot_table(
        index=["plant", "plant_label", "scenario", "unit", "start"],
        columns="variant",
        values=metric,
        aggfunc="first",
        observed=True,
    )


def _variants(columns: Sequence[str]) -> list[str]:
    order = [*PAIR_ORDER, "true"]
    return [v for v in order if v in columns]


def _groups(results: pd.DataFrame) -> Iterator[tuple[Any, ...]]:
    """Per metric (:data:`METRICS`) and plant/scenario group: ``(metric, unit, (plant,
    plant_label, scenario), per-unit table, per-run table)``, the tables with one column
    per variant (:func:`_unit_table`, :func:`_run_table`)."""
    df = prepare(results)
    for metric, unit in METRICS.items():
        if metric not in df or df[metric].isna().all():
            continue  # results written before the metric existed
        per_unit = _unit_table(df, metric)
        per_run = _run_table(df, metric)
        for key, g in per_unit.groupby(level=[0, 1, 2], sort=False):
            yield metric, unit, key, g, per_run.xs(key, level=[0, 1, 2])


def method_summary(results: pd.DataFrame) -> pd.DataFrame:
    """Per plant, scenario, variant and metric (:data:`METRICS`): units, runs, mean with its
    95 % bootstrap interval over units, median, standard deviation, min and max over runs."""
    rows = []
    for metric, unit, (plant, label, scen), g, runs in _groups(results):
        for v in _variants(g.columns):
            if v == "true" and metric in ("thermal_part_nmi", *RESIDUAL_COLUMNS):
                continue  # zero by construction
            u = g[v].to_numpy(dtype=float)
            r = runs[v].to_numpy(dtype=float)
            lo, hi = bootstrap_ci(u)
            rows.append(
                {
                    "plant": plant,
                    "plant_label": label,
                    "scenario": scen,
                    "variant": v,
                    "method": LABELS[v],
                    "metric": metric,
                    "unit": unit,
                    "n units": int(np.isfinite(u).sum()),
                    "n runs": int(np.isfinite(r).sum()),
                    "mean": float(np.nanmean(u)),
                    "ci low": lo,
                    "ci high": hi,
                    "median": float(np.nanmedian(r)),
                    "sd": float(np.nanstd(r, ddof=1)) if r.size > 1 else math.nan,
                    "min": float(np.nanmin(r)),
                    "max": float(np.nanmax(r)),
                }
            )
    return pd.DataFrame(rows)


def paired_differences(results: pd.DataFrame) -> pd.DataFrame:
    """Every pair of methods (:data:`PAIR_ORDER`, a before b) per plant, scenario and
    metric, paired on the same unit and start.

    Columns: ``mean a``, ``mean b``, ``difference`` (mean of a − b over units, with ``diff
    ci low/high``, a Student-t interval over units), ``decrease %`` (of the mean, a → b,
    with ``decrease ci low/high``, the paper's measure; heavy-tailed errors make it
    unstable, so the report leads with the difference), ``units b better`` (a count, of
    ``n units``: units whose mean over their starts is lower with b), ``runs b better``
    (a count, of ``n runs``), ``best decrease over the runs %`` (the paper's "up to": the
    largest single-run decrease; a maximum, not an estimate).
    """
    rows = []
    for metric, unit, (plant, label, scen), g, runs in _groups(results):
        if metric in RESIDUAL_COLUMNS:
            continue  # a model's fit, not an outcome to compare pairwise
        for a, b in itertools.combinations(_variants(g.columns), 2):
            if "true" in (a, b):
                continue
            ua, ub = g[a].to_numpy(float), g[b].to_numpy(float)
            ra, rb = runs[a].to_numpy(float), runs[b].to_numpy(float)
            dlo, dhi = t_interval(ua - ub)
            plo, phi = paired_decrease_ci(ua, ub)
            with np.errstate(divide="ignore", invalid="ignore"):
                per_run_dec = 100.0 * (ra - rb) / ra
            rows.append(
                {
                    "plant": plant,
                    "plant_label": label,
                    "scenario": scen,
                    "metric": metric,
                    "unit": unit,
                    "a": a,
                    "b": b,
                    "comparison": f"{LABELS[a]} → {LABELS[b]}",
                    "n units": len(ua),
                    "n runs": len(ra),
                    "mean a": float(np.nanmean(ua)),
                    "mean b": float(np.nanmean(ub)),
                    "difference": float(np.nanmean(ua - ub)),
                    "diff ci low": dlo,
                    "diff ci high": dhi,
                    "decrease %": float(_decrease(ua, ub)),
                    "decrease ci low": plo,
                    "decrease ci high": phi,
                    "units b better": int(np.sum(ub < ua)),
                    "runs b better": int(np.sum(rb < ra)),
                    "best decrease over the runs %": float(np.nanmax(per_run_dec)),
                }
            )
    return pd.DataFrame(rows)


def resolved(lo: float, hi: float) -> str:
    """``"b better"`` when a 95 % interval of a − b lies above zero, ``"a better"`` below,
    ``"not resolved"`` when it contains zero (or is undefined)."""
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return "not resolved"
    if lo > 0:
        return "b better"
    if hi < 0:
        return "a better"
    return "not resolved"


#: The paper's navigation claims: (scenario kind, method a, method b, the paper's figure,
#: what the figure is).
PAPER_CLAIMS = (
    ("quasi-static", "sectional", "regression", PAPER["lab_qs_m1_to_m2_pct"], "up to"),
    ("swing", "sectional", "regression", PAPER["lab_swing_m1_to_m2_pct"], "up to"),
    ("quasi-static", "regression", "neural", PAPER["lab_qs_m2_to_m3_pct"], "up to"),
    ("swing", "regression", "neural", PAPER["lab_swing_m2_to_m3_pct"], "up to"),
    ("vehicle", "sectional", "neural", PAPER["vehicle_m1_to_m3_mean_pct"], "mean"),
    ("vehicle", "sectional", "neural", PAPER["vehicle_m1_to_m3_max_pct"], "up to"),
)


def claims_table(results: pd.DataFrame, pairs: pd.DataFrame) -> pd.DataFrame:
    """Each claim of the paper (:data:`PAPER_CLAIMS`) per plant and scenario of that kind:
    our mean decrease of the maximum position error with its interval, our best run, and a
    verdict in words."""
    kinds = results.drop_duplicates("scenario").set_index("scenario")["kind"]
    p = pairs[pairs["metric"] == "max_error_nmi"]
    rows = []
    for kind, a, b, paper, what in PAPER_CLAIMS:
        for scen in kinds.index[kinds == kind]:
            sel = p[(p["scenario"] == scen) & (p["a"] == a) & (p["b"] == b)]
            for _, r in sel.iterrows():
                lo, hi = r["decrease ci low"], r["decrease ci high"]
                rows.append(
                    {
                        "plant": r["plant_label"],
                        "scenario": scen,
                        "claim": f"{LABELS[a]} → {LABELS[b]}: {paper:.2f} % less max "
                        f"position error ({what})",
                        "paper %": paper,
                        "paper's figure is": "its best run" if what == "up to" else "its mean",
                        "n units": r["n units"],
                        "ours: mean decrease %": r["decrease %"],
                        "ci low": lo,
                        "ci high": hi,
                        "ours: best run %": r["best decrease over the runs %"],
                        "difference a − b [nmi]": r["difference"],
                        "diff ci low": r["diff ci low"],
                        "diff ci high": r["diff ci high"],
                        "units b better": r["units b better"],
                        "verdict": claim_verdict(paper, what, lo, hi, r),
                    }
                )
    return pd.DataFrame(rows)


def claim_verdict(paper: float, what: str, lo: float, hi: float, r: pd.Series) -> str:
    """The verdict on one claim, in words, from our 95 % interval ``[lo, hi]`` of the mean
    decrease [%] and the paper's figure (a best run for ``what == "up to"``)."""
    if not (math.isfinite(lo) and math.isfinite(hi)):
        n = int(r["n units"]) if "n units" in r else 0
        return f"undecided: {not_enough(n)}"
    if hi < 0:
        worse = f"{LABELS[r['b']]} is worse"
        if "mean a" in r and r["mean a"] > 0:
            worse += f": its mean error is {r['mean b'] / r['mean a']:.1f}× {LABELS[r['a']]}'s"
        return (
            f"reversed: {worse} (decrease {r['decrease %']:.0f} %, interval {lo:.0f} … {hi:.0f} %)"
        )
    if lo <= 0:
        return f"not shown: the interval {lo:.0f} … {hi:.0f} % contains zero"
    base = f"direction holds: {r['decrease %']:.0f} % less on average ({lo:.0f} … {hi:.0f} %)"
    if what == "up to":
        best = r["best decrease over the runs %"]
        return (
            f"{base}; the paper's {paper:.1f} % is its best run, ours reaches {best:.0f} % "
            "in a single run"
        )
    if lo <= paper <= hi:
        return f"{base}; the paper's mean {paper:.1f} % lies inside"
    side = "above" if paper > hi else "below"
    return f"{base}; the paper's mean {paper:.1f} % lies {side} it"


def uncompensated_wins(pairs: pd.DataFrame) -> list[str]:
    """Sentences for every plant, scenario and method where no compensation has the lower
    mean maximum position error, with the paired difference (method − none) [nmi], its
    interval and the verdict (:func:`rinscal.experiments.study.compare.decide`): resolved
    either way, no resolved difference, or not enough units for an interval."""
    p = pairs[(pairs["metric"] == "max_error_nmi") & (pairs["a"] == "none")]
    out = []
    for _, r in p.iterrows():
        if r["mean b"] > r["mean a"]:
            name = LABELS[r["b"]]
            # difference is a − b = none − method; the verdict is on method − none
            lo, hi = -r["diff ci high"], -r["diff ci low"]
            verdict = decide(int(r["n units"]), lo, hi, "no compensation", name)
            ci = f" [{lo:+.3f}, {hi:+.3f}]" if math.isfinite(lo) and math.isfinite(hi) else ""
            out.append(
                f"{r['plant_label']}, {r['scenario']}: no compensation has the lower mean "
                f"error ({r['mean a']:.3f} nmi against {r['mean b']:.3f} nmi with {name}; "
                f"{name} − none = {-r['difference']:+.3f} nmi{ci}) — {verdict}"
            )
    return out


def _verdict_kind(verdict: str) -> str:
    """The verdict's first words: ``direction holds``, ``not shown``, ``reversed`` or
    ``undecided``."""
    return verdict.split(":")[0]


def structure_pairs(plants: pd.DataFrame) -> list[tuple[pd.Series, pd.Series]]:
    """Plant variants that differ only in their thermal law: every (polynomial,
    mechanistic) pair with the same sweep factors (the ``law`` column of
    :func:`rinscal.experiments.study.spec.plant_table`)."""
    if "law" not in plants or plants.empty:
        return []
    sweep = [c for c in plants.columns if c not in ("plant", "plant_label", "imu", "law")]
    out = []
    for _, g in plants.groupby(sweep, sort=False) if sweep else [(None, plants)]:
        poly = g[g["law"] == "polynomial"]
        mech = g[g["law"] == "mechanistic"]
        out += [(a, b) for _, a in poly.iterrows() for _, b in mech.iterrows()]
    return out


def structure_findings(
    claims: pd.DataFrame,
    summary: pd.DataFrame,
    plants: pd.DataFrame,
    pairs: pd.DataFrame | None = None,
) -> list[str]:
    """Which findings survive a change of the plant's thermal law, in words.

    For every pair of plants that differ only in their law (:func:`structure_pairs`): each
    claim's verdict on both, said to survive when the verdicts agree; with ``pairs``
    (:func:`paired_differences`), whether each model beats no compensation on both (the
    decrease of the mean maximum position error with its interval); and, as the reason, how
    much of the horizontal accelerometers' thermal swing each model leaves on the cold starts
    of each plant (``accel_residual_pct``, mean over units with its interval): a model class
    that cannot follow the mechanistic law leaves more of it there.
    """
    out: list[str] = []
    for poly, mech in structure_pairs(plants):
        pl, ml = poly["plant_label"], mech["plant_label"]
        if not claims.empty:
            for (scen, claim), g in claims.groupby(["scenario", "claim"], sort=False):
                a = g[g["plant"] == pl]
                b = g[g["plant"] == ml]
                if a.empty or b.empty:
                    continue
                a, b = a.iloc[0], b.iloc[0]
                ka, kb = _verdict_kind(a["verdict"]), _verdict_kind(b["verdict"])
                fa = _pct_ci(a["ours: mean decrease %"], a["ci low"], a["ci high"])
                fb = _pct_ci(b["ours: mean decrease %"], b["ci low"], b["ci high"])
                tail = _survival(ka, kb)
                out.append(f"{scen}, {claim}: {ka} on {pl} ({fa}), {kb} on {ml} ({fb}) — {tail}")
        if pairs is not None and not pairs.empty:
            out += _against_none(pairs, pl, ml)
        if summary.empty:
            continue
        res = summary[summary["metric"] == "accel_residual_pct"]
        for v in PAIR_ORDER[1:]:
            parts = []
            for scen in dict.fromkeys(res["scenario"]):
                here = res[(res["scenario"] == scen) & (res["variant"] == v)]
                a = here[here["plant_label"] == pl]
                b = here[here["plant_label"] == ml]
                if a.empty or b.empty:
                    continue
                a, b = a.iloc[0], b.iloc[0]
                pa = _pct_ci(a["mean"], a["ci low"], a["ci high"])
                pb = _pct_ci(b["mean"], b["ci low"], b["ci high"])
                parts.append(f"{scen} {pa} against {pb}")
            if parts:
                out.append(
                    f"{LABELS[v]} leaves of the horizontal accelerometers' thermal swing on the "
                    f"cold starts (RMS about the run's mean, worse of x and y), {pl} against "
                    f"{ml}: " + "; ".join(parts)
                )
    return out


def _against_none(pairs: pd.DataFrame, pl: str, ml: str) -> list[str]:
    """Per scenario and model: does it beat no compensation on both plants (the paired
    difference model − none [nmi] and its interval)?"""
    p = pairs[(pairs["metric"] == "max_error_nmi") & (pairs["a"] == "none")]
    out = []
    kinds = {"b better": "beats no compensation", "a better": "loses to no compensation"}
    for (scen, b), g in p.groupby(["scenario", "b"], sort=False):
        ra, rb = g[g["plant_label"] == pl], g[g["plant_label"] == ml]
        if ra.empty or rb.empty:
            continue
        ra, rb = ra.iloc[0], rb.iloc[0]
        k = [
            kinds.get(resolved(r["diff ci low"], r["diff ci high"]), "no resolved difference")
            for r in (ra, rb)
        ]
        n = min(int(ra["n units"]), int(rb["n units"]))
        decided = all(math.isfinite(r["diff ci low"]) for r in (ra, rb))
        tail = _survival(
            *(k if decided else ("undecided",) * 2), unresolved="no resolved difference", n=n
        )
        fa, fb = (
            _nmi_ci(-r["difference"], -r["diff ci high"], -r["diff ci low"]) for r in (ra, rb)
        )
        if not decided:
            k = ["undecided"] * 2
        out.append(
            f"{scen}, {LABELS[b]} − no compensation: {k[0]} on {pl} ({fa}), "
            f"{k[1]} on {ml} ({fb}) — {tail}"
        )
    return out


def _nmi_ci(m: float, lo: float, hi: float) -> str:
    """``+0.123 nmi [+0.01, +0.2]``, or without the interval where there is none."""
    if math.isfinite(lo) and math.isfinite(hi):
        return f"{m:+.3f} nmi [{lo:+.3f}, {hi:+.3f}]"
    return f"{m:+.3f} nmi, no interval"


def _survival(ka: str, kb: str, unresolved: str = "not shown", n: int | None = None) -> str:
    """Whether a verdict survives the change of law, from its kinds on both plants
    (``undecided``: no interval; ``unresolved``: the word for an interval containing 0)."""
    if "undecided" in (ka, kb):
        return "not decided: " + (
            not_enough(n) if n is not None else "not enough units for an interval"
        )
    if ka == kb == unresolved:
        return "resolved on neither plant"
    if ka == kb:
        return "survives the change of thermal law"
    return "does NOT survive the change of thermal law"


def _pct_ci(m: float, lo: float, hi: float) -> str:
    """``m % [lo, hi]``, or ``m % (no interval)`` where there is none (too few units)."""
    if math.isfinite(lo) and math.isfinite(hi):
        return f"{m:.0f} % [{lo:.0f}, {hi:.0f}]"
    return f"{m:.0f} % (no interval)"


__all__ = [
    "CONFIDENCE",
    "METRICS",
    "MIN_SAMPLES",
    "PAIR_ORDER",
    "PAPER_CLAIMS",
    "bootstrap_ci",
    "claim_verdict",
    "claims_table",
    "decide",
    "method_summary",
    "not_enough",
    "paired_decrease_ci",
    "paired_differences",
    "prepare",
    "resolved",
    "structure_findings",
    "structure_pairs",
    "uncompensated_wins",
]
