"""The reproduction report's navigation sections on *why* runs differ: the mechanism (bias
rate and the heading error it leaves; bias change within a modulation period; error
growth as drift rate and CEP) and the oracle's decomposition of each run's error.

Every number here was computed in :mod:`rinscal.experiments.paper.mechanism`; this module
only words and formats them.
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping
from typing import Any

import pandas as pd

from rinscal.experiments.paper.config import group_label
from rinscal.experiments.paper.mechanism import MIN_CEP_RUNS, ORACLE_NO_OFFSETS, PREDICTED_COLUMN

__all__ = [
    "MECHANISM_TABLES",
    "SHOWN_VARIANTS",
    "groups_view",
    "mechanism_section",
    "mechanism_words",
    "nav_sections",
    "oracle_loss_words",
    "oracle_section",
    "run_table_view",
]

#: The tables these sections add to the reproduction (written to tables/<name>.csv).
MECHANISM_TABLES = ("mechanism", "modulation", "error_growth", "cep", "oracle_decomposition")
#: Variants the per-run tables show in the page (the CSV files hold every variant).
SHOWN_VARIANTS = ("none", "regression", "true", ORACLE_NO_OFFSETS)


def _shown(df: pd.DataFrame, labels: Mapping[str, str]) -> pd.DataFrame:
    d = df[df["variant"].isin(SHOWN_VARIANTS)].copy()
    d["variant"] = d["variant"].map(lambda v: labels.get(v, v))
    return d


def run_table_view(df: pd.DataFrame, labels: Mapping[str, str], unit: str) -> pd.DataFrame:
    """A per-run table (columns ``experiment``/``scenario``/``number``/``ambient_c``/
    ``hours`` and one per variant) with readable headers for the page: the run named in
    words ("lab quasi-static 1", "ramp 1"), the ambient in °C ("chamber ramp" where it
    varies), the duration in h and each variant by its label with ``unit`` (e.g. "nmi",
    "″"). Other columns pass unchanged; the CSV file keeps the raw names."""
    exp = df["experiment"] if "experiment" in df else df["scenario"]
    out = pd.DataFrame(index=df.index)
    out["run"] = [
        f"{group_label(str(e), str(s))} {int(n)}"
        for e, s, n in zip(exp, df["scenario"], df["number"], strict=True)
    ]
    if "ambient_c" in df:
        out["ambient [°C]"] = [
            "chamber ramp" if pd.isna(a) else f"{float(a):g}" for a in df["ambient_c"]
        ]
    if "hours" in df:
        out["duration [h]"] = df["hours"].astype(float)
    skip = {"experiment", "scenario", "number", "ambient_c", "hours"}
    for c in df.columns:
        if c in skip:
            continue
        out[f"{labels[c]} [{unit}]" if c in labels else c] = df[c]
    return out.reset_index(drop=True)


def groups_view(df: pd.DataFrame) -> pd.DataFrame:
    """``experiment`` and ``scenario`` as one ``runs`` column in words ("ramp", "lab
    quasi-static": never "ramp ramp"); a ``runs`` count becomes ``n runs``."""
    names = [group_label(e, s) for e, s in zip(df["experiment"], df["scenario"], strict=True)]
    rest = df.drop(columns=["experiment", "scenario"]).rename(columns={"runs": "n runs"})
    return pd.concat([pd.DataFrame({"runs": names}, index=df.index), rest], axis=1)


def _f(x: float, spec: str = ".3g") -> str:
    """3 significant digits, never in exponent notation (1310, not 1.31e+03)."""
    if x is None or not math.isfinite(x):
        return "n/a"
    if spec == ".3g" and abs(x) >= 1000:
        return f"{x:,.0f}"
    return format(x, spec)


def oracle_loss_words(loss: Mapping[str, Any]) -> str:
    """One run where the oracle loses to no compensation, in words from its numbers
    (:func:`rinscal.experiments.paper.mechanism.oracle_loss_reasons`)."""
    parts = [
        f"{loss['run']}: the oracle ends at {_f(loss['oracle_nmi'])} nmi against "
        f"{_f(loss['none_nmi'])} nmi without compensation."
    ]
    ang = loss["angle_deg"]
    if math.isfinite(ang) and ang > 90:
        parts.append(
            f"At the oracle's maximum its error vector and the thermal part's (none − oracle) "
            f"point {ang:.0f}° apart, so without compensation the two partly cancel; "
            "removing the thermal part alone removes that cancellation."
        )
    elif math.isfinite(ang):
        parts.append(
            f"At the oracle's maximum its error and the thermal part's point {ang:.0f}° "
            "apart (they add); the oracle's larger maximum comes at another time."
        )
    cost = loss["offsets_cost_nmi"]
    if math.isfinite(cost):
        if cost > 0:
            parts.append(
                f"Of the rest, the turn-on offsets cost {_f(cost)} nmi (the oracle without "
                f"them: {_f(loss['no_offsets_nmi'])} nmi)."
            )
        else:
            parts.append(
                f"The turn-on offsets are not the cause: without them the oracle gets "
                f"{_f(loss['no_offsets_nmi'])} nmi, so noise and the alignment remain."
            )
    zo, zt = loss["gyro_z_offset_dph"], loss["gyro_z_thermal_dph"]
    if math.isfinite(zo):
        s = (
            f"The vertical gyro's turn-on offset ({zo:+.2g} °/h), which the single-axis "
            "rotation cannot modulate and the alignment cannot estimate, turns the heading "
            "all run long"
        )
        if loss["z_cancel"]:
            s += (
                f"; the uncompensated thermal residual of that gyro in navigation "
                f"({zt:+.2g} °/h) has the opposite sign and takes part of it back."
            )
        else:
            s += f"; the uncompensated thermal residual of that gyro ({zt:+.2g} °/h) adds to it."
        parts.append(s)
    return " ".join(parts)


def mechanism_words(summary: Mapping[str, Any]) -> str:
    """The mechanism table's paragraph, from :func:`rinscal.experiments.paper.mechanism.
    mechanism_summary`'s numbers (rates [µg/min], heading errors [″])."""
    words = (
        f"In our {summary['n_runs']} runs the uncompensated residual of the horizontal "
        f"accelerometers changes by {_f(summary['median_accel_rate_ug_min'])} µg/min during "
        "the fine alignment (median, IMU frame); the heading error the alignment hands over "
        "because of the thermal residual (uncompensated minus oracle, same raw output) is "
        f"{_f(summary['median_abs_thermal_heading_arcsec'])}″ (median |measured|). "
    )
    n, k = summary["n_runs"], summary.get("n_predicted", 0)
    if k:
        words += (
            f"In {k} of {n} runs the table held still through the fine alignment; there the "
            f"fixed-IMU formula predicts {_f(summary['median_abs_predicted_arcsec'])}″ (median "
            f"|predicted|); the measured thermal part is {_f(summary['attenuation'], '.2f')} "
            f"of it in size (median ratio), with the same sign in {summary['same_sign']} of "
            f"those {k}. "
        )
    if k < n:
        words += (
            f"In {n - k} of {n} runs the table indexes during the alignment, and there the "
            "formula gives no prediction: the turning table makes the horizontal biases "
            "observable, the filter's Gauss-Markov bias states follow most of a drift, and "
            "the heading error is set by how they follow it. "
        )
    return words + (
        "Against the same filter (tests/experiments/test_mechanism_prediction.py): with "
        "the table still, a constant horizontal gyro bias and an accelerometer bias rate "
        "give the formula's heading error within 10 %, each term resolved with the "
        "attitude at its instant; with the table indexing, the constant gyro bias leaves "
        "almost no heading error and a bias rate a fraction of the fixed-IMU figure (under a "
        "third), and the formula, even resolved with the attitude at each instant, misses "
        "both by more than twice their size; so the table leaves the prediction out rather "
        "than claim it."
    )


def mechanism_section(
    rep: Any,
    tables: Mapping[str, pd.DataFrame],
    figures: Mapping[str, bytes],
    summary: Mapping[str, Any],
    labels: Mapping[str, str],
) -> None:
    """ "Why runs differ: the mechanism" (section id ``mechanism``)."""
    s = rep.section("Why runs differ: the mechanism", "mechanism")
    s.text(
        "A navigation engineer reads a cold start as a chain. The thermal bias the "
        "compensation leaves (its residual) changes during the alignment; the levelling "
        "holds the velocity at zero, so the tilt follows the levelled accelerometer bias "
        "(tilt = bias / g) and a bias rate becomes a tilt rate; gyrocompassing cannot tell a "
        "tilt rate from a horizontal angular rate and attributes it to Earth rate, which for "
        "a fixed IMU hands over the heading error δψ = (−ε_E + ∇̇_N/g) / (Ω cos L); a "
        "heading error then makes a position error growing at about R Ω cos L · δψ. "
        "Rotation modulation assumes the bias constant over one rotation period, and the "
        "vertical gyro, not modulated by a single-axis table, turns the heading all run."
    )
    s.text(mechanism_words(summary))
    s.table(
        "mechanism",
        _shown(tables["mechanism"], labels),
        "Alignment: the residual's horizontal accelerometer rate and gyro bias in the IMU "
        "frame (fine alignment), the heading error measured at the start of navigation and "
        "its thermal part (variant − oracle)"
        + (
            ", and the fixed-IMU formula's prediction (runs whose table held still)"
            if PREDICTED_COLUMN in tables["mechanism"]
            else ""
        )
        + "; shown: "
        + ", ".join(labels.get(v, v) for v in SHOWN_VARIANTS)
        + " (every variant in tables/mechanism.csv)",
        float_format="{:.3g}",
        fold=True,
    )
    s.text(
        "How far from constant the residual bias is within one rotation period (the "
        "largest peak-to-peak change within any window of one period), during the "
        "alignment (where the warm-up transient sits) and during free navigation, and the "
        "vertical gyro's residual and turn-on offset that turn the heading:"
    )
    s.table(
        "modulation",
        _shown(tables["modulation"], labels),
        "Bias change within one modulation period [µg, °/h] and the vertical gyro's "
        "residual and turn-on offset [°/h] (every variant in tables/modulation.csv)",
        float_format="{:.3g}",
        fold=True,
    )
    s.text(
        "Error growth beside the maximum: the drift rate is the least-squares slope of the "
        "radial error against time over free navigation (intercept free); the CEP of a "
        "group is the median of its runs' final radial errors (the radius of the circle "
        "holding half the runs). A run's median error over its own duration is not a CEP, "
        "so none is given per run."
    )
    s.table(
        "error_growth",
        _shown(tables["error_growth"], labels),
        "Maximum and final radial error [nmi] and drift rate [nmi/h] per run "
        "(every variant in tables/error_growth.csv)",
        float_format="{:.3g}",
        fold=True,
    )
    cep = tables["cep"].copy()
    cep["variant"] = cep["variant"].map(lambda v: labels.get(v, v))
    col = "CEP (median final) [nmi]"
    cep[col] = [
        _f(x) if n >= MIN_CEP_RUNS else f"none (n = {n})"
        for x, n in zip(cep[col], cep["n runs"], strict=True)
    ]
    s.table(
        "cep",
        cep,
        "CEP per group of runs (median of the final radial errors) beside the median "
        "maximum and the median drift rate [nmi, nmi/h]; no CEP for a group of fewer than "
        f"{MIN_CEP_RUNS} runs",
        float_format="{:.3g}",
        fold=True,
    )
    if "heading_velocity" in figures:
        s.text(
            "The figure below shows the heading error and the horizontal velocity error "
            "against time for every variant of the first quasi-static and the first vehicle "
            "run, to show the mechanism at work: the heading error handed over by the "
            "alignment, the vertical gyro turning it during the run, and the velocity "
            "error it drives."
        )
        s.figure(
            "heading_velocity",
            figures["heading_velocity"],
            "Heading error and |velocity error| per variant (first quasi-static and first "
            "vehicle run)",
            fold=True,
        )


def oracle_section(
    rep: Any,
    tables: Mapping[str, pd.DataFrame],
    summary: Mapping[str, Any],
    labels: Mapping[str, str] | None = None,
) -> None:
    """ "The oracle: what the thermal model alone costs" (section id ``thermal-part``);
    ``labels`` name the variants in the per-run tables' headers."""
    labels = labels or {}
    s = rep.section("The oracle: what the thermal model alone costs", "thermal-part")
    s.text(
        "Every variant of a run navigates the same raw output, and the navigation errors "
        "are linear in small sensor errors, so a run's error vector splits into parts: the "
        "thermal part (uncompensated minus the oracle, which removes the true thermal "
        "errors), the turn-on offsets' part (the oracle minus a second counterfactual that "
        "also removes the power-on's constant offsets) and the rest (that counterfactual: "
        "noise, bias random walk, outliers, the accelerometers' size effect and the "
        "alignment's own errors). The parts are vectors: the maximum of a sum is not the sum "
        "of the maxima, and the thermal part can point against the rest."
    )
    s.table(
        "oracle_decomposition",
        tables["oracle_decomposition"],
        "Per run: maximum radial error without compensation, with the oracle, with the "
        "oracle and the turn-on offsets removed [nmi]; thermal part (signed difference of "
        "the maxima) [nmi]; angle between the thermal part's and the rest's error vectors at "
        "the oracle's maximum [°]; heading error at the start of navigation [″]",
        float_format="{:.3g}",
        fold=True,
    )
    n, k = summary["n_runs"], summary["oracle_loses"]
    if k == 0:
        s.text(
            f"The oracle beats no compensation in all {n} runs. The turn-on offsets cost a "
            f"median {_f(summary['median_offsets_cost_nmi'])} nmi of the oracle's maximum."
        )
    else:
        s.text(
            f"The oracle loses to no compensation in {k} of {n} runs. That is not the "
            "thermal model: a single run's error is the vector sum of the thermal part and "
            "errors no thermal model removes, and on these runs the two partly cancelled. "
            "Over many units the oracle wins (tests/nav/test_oracle_physics.py: paired "
            "differences over independent cold starts, interval excluding zero). The turn-on "
            f"offsets cost a median {_f(summary['median_offsets_cost_nmi'])} nmi of the "
            "oracle's maximum. Run by run:"
        )
        items = "".join(f"<li>{_esc(oracle_loss_words(x))}</li>" for x in summary["oracle_losses"])
        s.raw(f"<ul>{items}</ul>")
    s.text(
        "Hence the thermal part of a model's error is measured against the oracle (variant − "
        "oracle on the same raw output): it is the error the model's thermal misfit causes, "
        "whatever the rest does. Its maximum over each run:"
    )
    s.table(
        "thermal_part",
        run_table_view(tables["thermal_part"], labels, "nmi"),
        "Maximum position error caused by the thermal-model error alone [nmi]",
        fold=True,
    )
    s.table(
        "heading_at_nav_start",
        run_table_view(tables["heading_at_nav_start"], labels, "″"),
        "Heading error at the start of free navigation per run and variant [arcsec] "
        "(signed; blank where the navigation summary does not report it)",
        fold=True,
    )


def _esc(text: str) -> str:
    return html.escape(text)


def nav_sections(
    rep: Any,
    tables: Mapping[str, pd.DataFrame],
    figures: Mapping[str, bytes],
    summary: Mapping[str, Any] | None,
    labels: Mapping[str, str],
) -> None:
    """Both sections, in order; without the mechanism tables (an older result) only the
    oracle's thermal-part tables."""
    if summary is None or not all(t in tables for t in MECHANISM_TABLES):
        s = rep.section("The oracle: what the thermal model alone costs", "thermal-part")
        s.table("thermal_part", run_table_view(tables["thermal_part"], labels, "nmi"),
                "Maximum position error caused by the thermal-model error alone [nmi]",
                fold=True)  # fmt: skip
        s.table("heading_at_nav_start", run_table_view(tables["heading_at_nav_start"], labels,
                "″"), "Heading error at the start of free navigation per run and variant "
                "[arcsec]", fold=True)  # fmt: skip
        return
    mechanism_section(rep, tables, figures, summary, labels)
    oracle_section(rep, tables, summary, labels)
