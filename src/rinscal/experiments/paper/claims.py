"""The reproduction's summaries: the paper's headline numbers beside ours, the training-RMS
trends, the per-method statistics over groups of runs, where no compensation wins, and the
paper's claims checked on held-out data."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from rinscal.experiments.paper.calibration import CalibrationResult
from rinscal.experiments.paper.config import LABELS, METHODS, PAPER, PAPER_TABLES, VARIANTS
from rinscal.experiments.paper.paper_tables import paper_pulse_scales
from rinscal.experiments.verdict import (
    CONFIDENCE,
    change_words,
    claim_row,
    interval_text,
    paired,
    t_interval,
)
from rinscal.schema import ACCEL_CHANNELS, CHANNELS

__all__ = [
    "CLAIM_PAIRS",
    "NAV_GROUPS",
    "PAPER_PAIRS",
    "SUMMARY_COLUMNS",
    "claim_name",
    "claims",
    "decrease_pct",
    "group_means",
    "nav_group",
    "nav_method_table",
    "paired_claims",
    "paired_table",
    "selection_summary_table",
    "spread",
    "summary_table",
    "uncompensated_wins_heldout",
    "uncompensated_wins_nav",
]


def decrease_pct(a: float | np.ndarray, b: float | np.ndarray) -> float | np.ndarray:
    """Percentage decrease from ``a`` to ``b``: ``100 (a − b) / a``."""
    return 100.0 * (np.asarray(a) - np.asarray(b)) / np.asarray(a)


def spread(values: Sequence[float] | np.ndarray | pd.Series) -> dict[str, float]:
    """Mean and run-to-run spread of finite values: ``n``, ``mean``, ``sd`` (sample standard
    deviation, NaN for fewer than two runs), ``min``, ``max``."""
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    if x.size == 0:
        nan = float("nan")
        return {"n": 0, "mean": nan, "sd": nan, "min": nan, "max": nan}
    return {
        "n": int(x.size),
        "mean": float(x.mean()),
        "sd": float(x.std(ddof=1)) if x.size > 1 else float("nan"),
        "min": float(x.min()),
        "max": float(x.max()),
    }


def _per_run(values: Sequence[float] | np.ndarray | pd.Series, fmt: str = "{:.1f}") -> str:
    return " / ".join(fmt.format(float(v)) for v in values)


#: Columns of the headline table (:func:`summary_table`): the means and spreads first, the
#: best cases last and labelled as maxima.
SUMMARY_COLUMNS = (
    "quantity",
    "n runs",
    "paper: mean",
    "rinscal: mean",
    "rinscal: sd",
    "rinscal: min",
    "rinscal: max",
    "paper: maximum ('up to')",
    "note",
)


def summary_table(maxerr: pd.DataFrame) -> pd.DataFrame:
    """The paper's headline numbers beside ours (simulation).

    One row per headline quantity, computed per run: our mean over the runs with its
    spread (sample standard deviation, min and max, number of runs), the paper's mean where
    it publishes one and its maximum (the "up to" figures of the abstract and Section 5 are
    the best run). Our maximum is labelled as one too. Blank: not published. Percentages
    are the decrease of the maximum position error of a run from one method to another
    (:func:`decrease_pct`); the Table 10 rows are maximum position errors [nmi].
    ``maxerr`` is :func:`max_error_table`. The training-RMS trends of Tables 5 and 7 are in
    :func:`selection_summary_table`.
    """
    rows: list[dict[str, Any]] = []
    nan = float("nan")

    def add(what: str, ours: Any, paper_mean: float, paper_max: float, note: str) -> None:
        st = spread(ours)
        values = (what, st["n"], paper_mean, st["mean"], st["sd"], st["min"], st["max"])
        rows.append(dict(zip(SUMMARY_COLUMNS, (*values, paper_max, note), strict=True)))

    lab = maxerr[maxerr["experiment"] == "lab"]
    for scen, key12, key23 in (
        ("quasi-static", "lab_qs_m1_to_m2_pct", "lab_qs_m2_to_m3_pct"),
        ("swing", "lab_swing_m1_to_m2_pct", "lab_swing_m2_to_m3_pct"),
    ):
        sc = lab[lab["scenario"] == scen]
        for a, b, key, what in (
            ("sectional", "regression", key12, "method 1 → 2"),
            ("regression", "neural", key23, "method 2 → 3"),
        ):
            d = np.asarray(decrease_pct(sc[a], sc[b]), dtype=float)
            add(
                f"lab {scen}: decrease of max position error, {what} [%]",
                d,
                nan,
                PAPER[key],
                f"per run: {_per_run(d)}; the paper gives only its best run ('up to')",
            )
    veh = maxerr[maxerr["experiment"] == "vehicle"]
    d13 = np.asarray(decrease_pct(veh["sectional"], veh["neural"]), dtype=float)
    paper_d13 = decrease_pct(
        np.array(PAPER["table10_nmi"]["sectional"]), np.array(PAPER["table10_nmi"]["neural"])
    )
    add(
        "vehicle: decrease of max position error, method 1 → 3 [%]",
        d13,
        PAPER["vehicle_m1_to_m3_mean_pct"],
        PAPER["vehicle_m1_to_m3_max_pct"],
        f"per run: {_per_run(d13)}; paper (Table 10): {_per_run(paper_d13)}",
    )
    for m in ("sectional", "regression", "neural"):
        paper = np.array(PAPER["table10_nmi"][m], dtype=float)
        add(
            f"vehicle: max position error, {LABELS[m]} [nmi]",
            veh[m].to_numpy(dtype=float),
            float(paper.mean()),
            float(paper.max()),
            f"per run: {_per_run(veh[m], '{:.3f}')}; paper (Table 10): {_per_run(paper, '{:.3f}')}",
        )
    return pd.DataFrame(rows, columns=list(SUMMARY_COLUMNS))


def selection_summary_table(cal: CalibrationResult) -> pd.DataFrame:
    """Training RMS of Tables 5 and 7 for the x axis, the paper's beside ours, both in µg
    and °/h (the paper's pulses times :func:`paper_tables.paper_pulse_scales`), with the
    noise floor of our log (:func:`paper_tables.noise_floor`) the RMS sits on."""
    scales = paper_pulse_scales()
    rows: list[dict[str, Any]] = []

    def add(what: str, paper: str, ours: str, note: str) -> None:
        rows.append({"quantity": what, "paper": paper, "rinscal (simulation)": ours, "note": note})

    floor: dict[str, float] = {}
    for key in ("table5_accel", "table5_gyro"):
        t = cal.tables.get(key)
        if t is not None and len(t):
            for axis, f in zip(t["axis"], t["noise floor"], strict=True):
                floor[f"{key.split('_')[1]}_{axis}"] = float(f)

    def note(c: str, unit: str, dec: int) -> str:
        f = floor.get(c)
        return (
            "the paper's pulses converted"
            + ("" if f is None else f"; white-noise floor of our log {f:.{dec}f} {unit}")
            + "; compare the trend and the distance to the floor"
        )

    t5 = cal.selection["regression"].table
    t7 = cal.selection["neural"].table
    for c, unit, dec in (("accel_x", "µg", 1), ("gyro_x", "°/h", 4)):
        ours = t5[t5["channel"] == c].sort_values("setting")["rms_train"].to_numpy()
        paper = PAPER_TABLES["table5"][c]
        add(
            f"Table 5, {c}: training RMS for p=q=s=1..4 [{unit}]",
            " / ".join(f"{x * scales[c]:.{dec}f}" for x in paper),
            " / ".join(f"{x:.{dec}f}" for x in ours),
            note(c, unit, dec),
        )
    for c, unit, dec in (("accel_x", "µg", 1), ("gyro_x", "°/h", 4)):
        t = t7[t7["channel"] == c].set_index("setting")["rms_train"]
        paper = PAPER_TABLES["table7"][c]
        ks = sorted(paper)
        add(
            f"Table 7, {c}: training RMS for n={ks[0]}..{ks[-1]} neurons [{unit}]",
            " / ".join(f"{paper[k] * scales[c]:.{dec}f}" for k in ks),
            " / ".join(f"{t.get(k, float('nan')):.{dec}f}" for k in ks),
            note(c, unit, dec),
        )
    return pd.DataFrame(rows)


#: Groups of navigation runs the per-method statistics are given for.
NAV_GROUPS = (
    ("lab + vehicle", ("lab", "vehicle"), None),
    ("lab quasi-static", ("lab",), "quasi-static"),
    ("lab swing", ("lab",), "swing"),
    ("vehicle", ("vehicle",), None),
)


def nav_group(
    table: pd.DataFrame, experiments: Sequence[str], scenario: str | None
) -> pd.DataFrame:
    """The rows of ``table`` (one per run) of ``experiments``, of ``scenario`` if given."""
    sel = table["experiment"].isin(list(experiments))
    if scenario is not None:
        sel &= table["scenario"] == scenario
    return table[sel]


def nav_method_table(maxerr: pd.DataFrame, heading: pd.DataFrame) -> pd.DataFrame:
    """Per group of runs and variant: the maximum position error [nmi] and the absolute
    heading error at the start of navigation [arcsec], each as mean, sample standard
    deviation, min and max over the runs."""
    rows = []
    for group, exps, scen in NAV_GROUPS:
        me = nav_group(maxerr, exps, scen)
        he = nav_group(heading, exps, scen)
        if me.empty:
            continue
        for v in VARIANTS:
            e = spread(me[v])
            h = spread(np.abs(he[v].to_numpy(dtype=float)))
            rows.append(
                {
                    "runs": group,
                    "variant": v,
                    "method": LABELS[v],
                    "n runs": e["n"],
                    "max error mean [nmi]": e["mean"],
                    "max error sd [nmi]": e["sd"],
                    "max error min [nmi]": e["min"],
                    "max error max [nmi]": e["max"],
                    "|heading error| mean [arcsec]": h["mean"],
                    "|heading error| sd [arcsec]": h["sd"],
                    "|heading error| min [arcsec]": h["min"],
                    "|heading error| max [arcsec]": h["max"],
                    "n heading": h["n"],
                }
            )
    return pd.DataFrame(rows)


def uncompensated_wins_heldout(residual: pd.DataFrame, log: str) -> dict[str, list[str]]:
    """Per method, the channels of a held-out log on which no compensation beats it: the
    true thermal bias (``none`` row) has a smaller RMS than the method's residual."""
    rep = residual[residual["log"] == log].set_index("method")
    if "none" not in rep.index:
        return {}
    out: dict[str, list[str]] = {}
    for m in rep.index:
        if m == "none":
            continue
        lost = [c for c in CHANNELS if c in rep.columns and rep.loc[m, c] > rep.loc["none", c]]
        if lost:
            out[str(m)] = lost
    return out


def uncompensated_wins_nav(maxerr: pd.DataFrame) -> dict[str, dict[str, tuple[float, float]]]:
    """Per group of runs (:data:`NAV_GROUPS`), the methods whose mean maximum position error
    is larger than the uncompensated run's: ``{group: {method: (none_mean, method_mean)}}``
    [nmi]; the oracle is not a method and is left out."""
    out: dict[str, dict[str, tuple[float, float]]] = {}
    for group, exps, scen in NAV_GROUPS:
        g = nav_group(maxerr, exps, scen)
        if g.empty or "none" not in g:
            continue
        base = float(g["none"].mean())
        lost = {m: (base, float(g[m].mean())) for m in METHODS if m in g and g[m].mean() > base}
        if lost:
            out[group] = lost
    return out


def claims(cal: CalibrationResult) -> dict[str, Any]:
    """The paper's claims that are not in nmi, checked on held-out data [µg]: each with our
    numbers, its unit and whether it holds.

    ``asserted`` claims are the ones CI requires; the others are reported. The navigation
    claims are paired comparisons in nmi under one rule (:func:`paired_claims`).
    """
    out: dict[str, Any] = {}
    h = cal.tables["heldout_residual"]
    rep = h[h["log"] == "repeat"].set_index("method")
    acc = list(ACCEL_CHANNELS)
    sec = rep.loc["sectional", acc].astype(float)
    for m in ("regression", "neural"):
        ours = rep.loc[m, acc].astype(float)
        out[f"heldout_{m}_below_sectional_accels"] = {
            "asserted": True,
            "holds": bool(np.all(ours.to_numpy() < sec.to_numpy())),
            "values_ug": {c: [float(ours[c]), float(sec[c])] for c in acc},
            "what": f"held-out thermal residual on the repeat run, {m} < sectional, every "
            "accelerometer [µg, ours vs sectional]",
        }
        polyt = rep.loc["poly-t", acc].astype(float)
        out[f"heldout_{m}_below_polyt_accels"] = {
            "asserted": False,
            "holds": bool(np.all(ours.to_numpy() < polyt.to_numpy())),
            "values_ug": {c: [float(ours[c]), float(polyt[c])] for c in acc},
            "what": f"held-out thermal residual on the repeat run, {m} < poly-t baseline",
        }
    st = cal.tables["repeat_steps"].set_index(["method", "channel"])
    sec_steps = st.loc["sectional"].loc[acc, "model_step"].astype(float)
    for m in ("regression", "neural"):
        s = st.loc[m].loc[acc, "model_step"].astype(float)
        out[f"no_step_{m}"] = {
            "asserted": True,
            "holds": bool(np.nanmax(s.to_numpy()) < 0.1 * np.nanmax(sec_steps.to_numpy())),
            "values_ug": {
                "largest_step": float(np.nanmax(s.to_numpy())),
                "sectional_largest_step": float(np.nanmax(sec_steps.to_numpy())),
            },
            "what": f"{m}: largest model step at a segment edge on the repeat run is below a "
            "tenth of the sectional model's [µg]",
        }
    out["sectional_step_shows"] = {
        "asserted": True,
        "holds": bool(np.nanmax(sec_steps.to_numpy()) > 1.0),
        "values_ug": {"largest_step": float(np.nanmax(sec_steps.to_numpy()))},
        "what": "the sectional model steps at a segment edge on the repeat run (> 1 µg)",
    }
    return out


#: The paper's own comparisons (method 1 → 2, 2 → 3, 1 → 3) as ``(method, reference)``; with
#: each method against no compensation and against the cubic in T, the claims
#: (:data:`CLAIM_PAIRS`), each read "method better than reference".
PAPER_PAIRS = (("regression", "sectional"), ("neural", "regression"), ("neural", "sectional"))
CLAIM_PAIRS = (
    *PAPER_PAIRS,
    *((m, "none") for m in METHODS),
    *((m, "poly-t") for m in METHODS if m != "poly-t"),
)
#: Names of the references in a claim.
_REFERENCE_NAMES = {"none": "no compensation", "poly-t": "the cubic in T"}


def claim_name(method: str, reference: str) -> str:
    """``"method 2 (regression) better than method 1 (sectional)"``."""
    return f"{LABELS.get(method, method)} better than " + _REFERENCE_NAMES.get(
        reference, LABELS.get(reference, reference)
    )


def paired_claims(
    maxerr: pd.DataFrame,
    plant: str,
    pairs: Sequence[tuple[str, str]] = CLAIM_PAIRS,
) -> pd.DataFrame:
    """Each claim "method better than reference" per group of runs (:data:`NAV_GROUPS`),
    paired run by run under the one rule (:mod:`rinscal.experiments.verdict`).

    Parameters
    ----------
    maxerr : DataFrame
        One row per run with ``experiment, scenario`` and one column per variant [nmi].
    plant : str
        The plant's name, written in every row.
    pairs : sequence of (method, reference)
        The claims (default :data:`CLAIM_PAIRS`); pairs missing from ``maxerr`` are skipped.

    Returns
    -------
    DataFrame
        :data:`rinscal.experiments.verdict.CLAIMS_COLUMNS` (``mean_nmi`` and the interval:
        method − reference [nmi]), then ``method``, ``reference``, ``mean_method_nmi``,
        ``mean_reference_nmi`` and ``better`` (runs where the method has less error).
    """
    rows = []
    for group, exps, scen in NAV_GROUPS:
        g = nav_group(maxerr, exps, scen)
        if g.empty:
            continue
        for m, ref in pairs:
            if m not in g or ref not in g:
                continue
            p = paired(g[ref], g[m])
            rows.append(
                {
                    **claim_row(claim_name(m, ref), plant, group, p),
                    "method": m,
                    "reference": ref,
                    "mean_method_nmi": p.mean_method,
                    "mean_reference_nmi": p.mean_reference,
                    "better": p.better,
                }
            )
    return pd.DataFrame(rows)


def group_means(maxerr: pd.DataFrame, plant: str) -> pd.DataFrame:
    """Per group of runs (:data:`NAV_GROUPS`) and variant: ``plant, group, method, n,
    mean, lo, hi``, the mean maximum position error with its Student-t interval [nmi]
    (:func:`rinscal.experiments.verdict.t_interval`; NaN below its minimum n)."""
    rows = []
    for group, exps, scen in NAV_GROUPS:
        g = nav_group(maxerr, exps, scen)
        for v in VARIANTS:
            if g.empty or v not in g:
                continue
            x = g[v].to_numpy(dtype=float)
            x = x[np.isfinite(x)]
            lo, hi = t_interval(x)
            rows.append(
                {
                    "plant": plant,
                    "group": group,
                    "method": v,
                    "n": int(x.size),
                    "mean": float(x.mean()) if x.size else float("nan"),
                    "lo": lo,
                    "hi": hi,
                }
            )
    return pd.DataFrame(rows)


def paired_table(
    maxerr: pd.DataFrame,
    reference: str,
    variants: Sequence[str],
) -> pd.DataFrame:
    """Each variant against ``reference`` per group of runs (:data:`NAV_GROUPS`), under
    the one rule (:mod:`rinscal.experiments.verdict`).

    Parameters
    ----------
    maxerr : DataFrame
        One row per run with ``experiment, scenario`` and one column per variant [nmi]
        (:func:`rinscal.experiments.paper.navigation.max_error_table`).
    reference : str
        The variant every other is compared with (e.g. ``"none"``, ``"poly-t"``).
    variants : sequence of str
        The variants compared (those missing from ``maxerr`` are skipped).

    Returns
    -------
    DataFrame
        ``runs, variant, method, n runs, Δ mean [nmi]`` (variant − reference: negative =
        the variant has less error), ``95 % interval [nmi]`` (text, empty below the
        rule's minimum n), ``better in`` ("k of n" runs), ``mean error`` (the change of
        the mean, a description: "38 % less", "7.5× worse") and ``verdict`` (of
        "variant better than reference").
    """
    rows = []
    for group, exps, scen in NAV_GROUPS:
        g = nav_group(maxerr, exps, scen)
        if g.empty or reference not in g:
            continue
        for v in variants:
            if v == reference or v not in g:
                continue
            p = paired(g[reference], g[v])
            rows.append(
                {
                    "runs": group,
                    "variant": v,
                    "method": LABELS.get(v, v),
                    "n runs": p.n,
                    "Δ mean [nmi]": p.mean,
                    f"{CONFIDENCE:.0%} interval [nmi]": interval_text(p.lo, p.hi, p.mean),
                    "better in": f"{p.better} of {p.n}",
                    "mean error": change_words(p.mean_reference, p.mean_method),
                    "verdict": p.words,
                }
            )
    return pd.DataFrame(rows)
