"""Statistics of a study: means with their intervals, paired differences, the paper's
claims with a verdict each, the sensitivity map.

The unit of analysis is the simulated IMU unit. Where a scenario has several cold starts per
unit (the lab's five temperatures), they are averaged per unit first; intervals are over
units, so that starts of the same unit, which share its calibration, are not counted as
independent. Every interval and verdict is the one rule of :mod:`rinscal.experiments.verdict`:
a 95 % Student-t interval over units, given from
:data:`~rinscal.experiments.verdict.MIN_N` units on; comparisons between methods are paired
(both navigated on the same raw data of the same unit and start) and decided on the
difference in nmi. Percent decreases are descriptions of the same pairs, never the test.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
import pandas as pd

from rinscal.experiments.paper.claims import claim_name
from rinscal.experiments.paper.config import LABELS, PAPER
from rinscal.experiments.paper.navigation import RESIDUAL_COLUMNS
from rinscal.experiments.study.compare import FIELD_VARIANT, NO_DT_VARIANT
from rinscal.experiments.verdict import (
    CONFIDENCE,
    MIN_N,
    TOO_FEW,
    UNRESOLVED,
    change_words,
    paired,
    t_interval,
    too_few,
)

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
PAIR_ORDER = ("none", "poly-t", "sectional", "regression", NO_DT_VARIANT, "neural", FIELD_VARIANT)


def _decrease(a: np.ndarray, b: np.ndarray) -> float:
    """Decrease of the mean from ``a`` to ``b`` [%]: ``100 (mean a − mean b) / mean a``
    (a description)."""
    ma = float(np.mean(a))
    return 100.0 * (ma - float(np.mean(b))) / ma if ma else math.nan


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
    95 % Student-t interval over units (:func:`rinscal.experiments.verdict.t_interval`),
    median, standard deviation, min and max over runs."""
    rows = []
    for metric, unit, (plant, label, scen), g, runs in _groups(results):
        for v in _variants(g.columns):
            if v == "true" and metric in ("thermal_part_nmi", *RESIDUAL_COLUMNS):
                continue  # zero by construction
            u = g[v].to_numpy(dtype=float)
            r = runs[v].to_numpy(dtype=float)
            lo, hi = t_interval(u)
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
    the paper's measure, a description only), ``units b better`` (a count, of
    ``n units``: units whose mean over their starts is lower with b), ``runs b better``
    (a count, of ``n runs``), ``best decrease over the runs %`` (the paper's "up to": the
    largest single-run decrease; a maximum, not an estimate), ``verdict`` (on "b better
    than a", :func:`rinscal.experiments.verdict.verdict`).
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
            p = paired(ua, ub)  # b − a: negative = b has less error
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
                    "n units": p.n,
                    "n runs": len(ra),
                    "mean a": p.mean_reference,
                    "mean b": p.mean_method,
                    "difference": -p.mean,
                    "diff ci low": -p.hi,
                    "diff ci high": -p.lo,
                    "decrease %": _decrease(ua, ub),
                    "units b better": p.better,
                    "runs b better": int(np.sum(rb < ra)),
                    "best decrease over the runs %": float(np.nanmax(per_run_dec)),
                    "verdict": p.verdict,
                }
            )
    return pd.DataFrame(rows)


#: The paper's navigation claims: (scenario kind, method a, method b, the paper's figure,
#: what the figure is); each is tested as "b better than a".
PAPER_CLAIMS = (
    ("quasi-static", "sectional", "regression", PAPER["lab_qs_m1_to_m2_pct"], "up to"),
    ("swing", "sectional", "regression", PAPER["lab_swing_m1_to_m2_pct"], "up to"),
    ("quasi-static", "regression", "neural", PAPER["lab_qs_m2_to_m3_pct"], "up to"),
    ("swing", "regression", "neural", PAPER["lab_swing_m2_to_m3_pct"], "up to"),
    ("vehicle", "sectional", "neural", PAPER["vehicle_m1_to_m3_mean_pct"], "mean"),
)


def claims_table(results: pd.DataFrame, pairs: pd.DataFrame) -> pd.DataFrame:
    """Each claim of the paper (:data:`PAPER_CLAIMS`) per plant and scenario of that kind,
    tested under the one rule: ``claim`` ("b better than a"), the paper's figure, ``n
    units``, ``mean_nmi`` (b − a over units) with ``ci_low_nmi``/``ci_high_nmi``,
    ``ours: change`` (the change of the mean error, a description: "38 % less",
    "7.5× worse"), ``ours: best run %`` (the largest single-run decrease, the paper's
    "up to"), ``units b better`` and ``verdict`` (:func:`rinscal.experiments.verdict.verdict`).
    """
    kinds = results.drop_duplicates("scenario").set_index("scenario")["kind"]
    p = pairs[pairs["metric"] == "max_error_nmi"]
    rows = []
    for kind, a, b, paper, what in PAPER_CLAIMS:
        for scen in kinds.index[kinds == kind]:
            sel = p[(p["scenario"] == scen) & (p["a"] == a) & (p["b"] == b)]
            for _, r in sel.iterrows():
                rows.append(
                    {
                        "plant": r["plant_label"],
                        "scenario": scen,
                        "a": a,
                        "b": b,
                        "claim": claim_name(b, a),
                        "paper": f"{paper:.2f} % less ("
                        + ("its best run" if what == "up to" else "its mean")
                        + ")",
                        "n units": int(r["n units"]),
                        "mean_nmi": -float(r["difference"]),
                        "ci_low_nmi": -float(r["diff ci high"]),
                        "ci_high_nmi": -float(r["diff ci low"]),
                        "ours: change": change_words(r["mean a"], r["mean b"]),
                        "ours: best run %": r["best decrease over the runs %"],
                        "units b better": int(r["units b better"]),
                        "verdict": r["verdict"],
                    }
                )
    return pd.DataFrame(rows)


def uncompensated_wins(pairs: pd.DataFrame) -> list[str]:
    """Sentences for every plant, scenario and method where no compensation has the lower
    mean maximum position error, with the paired difference (method − none) [nmi], its
    interval and the verdict on "method better than no compensation"
    (:func:`rinscal.experiments.verdict.verdict`)."""
    p = pairs[(pairs["metric"] == "max_error_nmi") & (pairs["a"] == "none")]
    out = []
    for _, r in p.iterrows():
        if r["mean b"] > r["mean a"]:
            name = LABELS[r["b"]]
            # difference is a − b = none − method; the verdict is on method − none
            lo, hi = -r["diff ci high"], -r["diff ci low"]
            words = r["verdict"] if r["verdict"] != TOO_FEW else too_few(int(r["n units"]), "units")
            ci = f" [{lo:+.3f}, {hi:+.3f}]" if math.isfinite(lo) and math.isfinite(hi) else ""
            out.append(
                f"{r['plant_label']}, {r['scenario']}: no compensation has the lower mean "
                f"error ({r['mean a']:.3f} nmi against {r['mean b']:.3f} nmi with {name}; "
                f"{name} − none = {-r['difference']:+.3f} nmi{ci}) — {name} better than no "
                f"compensation: {words}"
            )
    return out


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
    claim's verdict on both (the one rule), said to survive when the verdicts agree; with
    ``pairs`` (:func:`paired_differences`), whether each model beats no compensation on both
    (the paired difference model − none [nmi] with its interval); and, as the reason, how
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
                ka, kb = a["verdict"], b["verdict"]
                fa = _nmi_ci(a["mean_nmi"], a["ci_low_nmi"], a["ci_high_nmi"])
                fb = _nmi_ci(b["mean_nmi"], b["ci_low_nmi"], b["ci_high_nmi"])
                tail = _survival(ka, kb, n=min(int(a["n units"]), int(b["n units"])))
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
    """Per scenario and model: the verdict on "model better than no compensation" on both
    plants (the paired difference model − none [nmi] and its interval)."""
    p = pairs[(pairs["metric"] == "max_error_nmi") & (pairs["a"] == "none")]
    out = []
    for (scen, b), g in p.groupby(["scenario", "b"], sort=False):
        ra, rb = g[g["plant_label"] == pl], g[g["plant_label"] == ml]
        if ra.empty or rb.empty:
            continue
        ra, rb = ra.iloc[0], rb.iloc[0]
        k = [str(r["verdict"]) for r in (ra, rb)]
        tail = _survival(*k, n=min(int(ra["n units"]), int(rb["n units"])))
        fa, fb = (
            _nmi_ci(-r["difference"], -r["diff ci high"], -r["diff ci low"]) for r in (ra, rb)
        )
        out.append(
            f"{scen}, {LABELS[b]} better than no compensation: {k[0]} on {pl} ({fa}), "
            f"{k[1]} on {ml} ({fb}) — {tail}"
        )
    return out


def _nmi_ci(m: float, lo: float, hi: float) -> str:
    """``+0.123 nmi [+0.01, +0.2]``, or without the interval where there is none."""
    if math.isfinite(lo) and math.isfinite(hi):
        return f"{m:+.3f} nmi [{lo:+.3f}, {hi:+.3f}]"
    return f"{m:+.3f} nmi, no interval"


def _survival(ka: str, kb: str, n: int) -> str:
    """Whether a verdict survives the change of law, from its verdicts on both plants."""
    if TOO_FEW in (ka, kb):
        return "not decided: " + too_few(n, "units")
    if ka == kb == UNRESOLVED:
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
    "MIN_N",
    "PAIR_ORDER",
    "PAPER_CLAIMS",
    "claims_table",
    "method_summary",
    "paired_differences",
    "prepare",
    "structure_findings",
    "structure_pairs",
    "uncompensated_wins",
]
