"""A study's numbers as the report shows them: narrow tables and sentences.

Each view takes a table computed in :mod:`rinscal.experiments.study` and returns what the
report prints: at most 8 columns, headers with units, intervals formatted as ``[−0.11,
−0.03]`` with the decimals of the estimate beside them, counts as counts (``2 of 3``), and
below :data:`rinscal.experiments.verdict.MIN_N` units the words "not enough runs (n = 3
units; needs 5)" instead of an interval. Nothing here computes a statistic.
"""

from __future__ import annotations

import html
import math
from collections.abc import Iterable
from typing import Any

import pandas as pd

from rinscal.experiments.study.compare import fmt_interval
from rinscal.experiments.verdict import CONFIDENCE, MIN_N, TOO_FEW, too_few
from rinscal.report.study_figures import short_label

__all__ = [
    "CODES",
    "CODES_LEGEND",
    "ablation_lines",
    "claims_view",
    "code",
    "codes_legend",
    "comparison_view",
    "design_view",
    "field_lines",
    "map_lines",
    "map_view",
    "oracle_lines",
    "pairs_view",
    "sensitivities_view",
    "short_verdict",
    "summary_view",
    "ul",
]


def _sg(x: float, nd: int = 2) -> str:
    """``+0.12`` / ``−0.12`` (a true minus sign)."""
    return f"{x:+.{nd}f}".replace("-", "−")


def _n_of(k: int, n: int) -> str:
    return f"{k} of {n}"


def _delta_words(r: pd.Series, nd: int = 3) -> str:
    """``+0.123 nmi [+0.05, +0.20]`` or ``+0.123 nmi (no interval: n = 3; needs 5)``."""
    ci = fmt_interval(r["delta ci low"], r["delta ci high"], nd)
    d = f"{r['delta']:+.{nd}f}".replace("-", "−")
    if ci:
        return f"{d} nmi {ci}"
    return f"{d} nmi (no interval: n = {int(r['n units'])}; needs {MIN_N})"


def oracle_lines(oracle: pd.DataFrame) -> list[str]:
    """Per plant and scenario: no compensation − oracle with its interval, and how many
    single runs the oracle lost."""
    out = []
    for _, r in oracle.iterrows():
        lost = int(r["runs method better"])
        verdict = r["verdict"]
        out.append(
            f"{r['plant_label']}, {r['scenario']}: no compensation − oracle = "
            f"{_delta_words(r)} over {int(r['n units'])} units"
            + ("" if verdict == TOO_FEW else f"; no compensation better than the oracle: {verdict}")
            + f"; the oracle lost {_n_of(lost, int(r['n runs']))} single runs to no "
            "compensation"
        )
    return out


def field_lines(field: pd.DataFrame) -> list[str]:
    """Per plant and scenario: the field calibration against the chamber's method 2 (the
    mean paired ratio of the maximum position error with its interval, the difference and
    the verdict) and against no compensation (the verdict)."""
    out = []
    for (label, scen), g in field.groupby(["plant_label", "scenario"], sort=False):
        parts = []
        for _, r in g.iterrows():
            ref = "method 2" if r["reference"] == "regression" else _label_ref(r["reference"])
            ci = fmt_interval(r["mean ratio ci low"], r["mean ratio ci high"], 2)
            ratio = f"mean ratio field / {ref} {r['mean ratio']:.2f}" + (f" {ci}" if ci else "")
            parts.append(
                f"{ratio}, field − {ref} = {_delta_words(r)}, field better than {ref}: "
                f"{short_verdict(int(r['n units']), r['verdict'])}"
            )
        n = g.iloc[0]
        out.append(
            f"{label}, {scen} ({int(n['n units'])} units, {int(n['n runs'])} starts): "
            + "; ".join(parts)
        )
    return out


def _label_ref(ref: str) -> str:
    return {"none": "no compensation", "poly-t": "the cubic in T"}.get(ref, CODES.get(ref, ref))


def ablation_lines(abl: pd.DataFrame, design: pd.DataFrame) -> list[str]:
    """Does the gradient pay apart from Ṫ: method 2 − method 2 without ΔT, and how well the
    soak design separates Ṫ from ΔT."""
    out = []
    for _, r in abl.iterrows():
        verdict = r["verdict"]
        out.append(
            f"{r['plant_label']}, {r['scenario']}: method 2 − method 2 without ΔT = "
            f"{_delta_words(r)}"
            + (
                ""
                if verdict == TOO_FEW
                else f"; method 2 better than method 2 without ΔT: {verdict}"
            )
            + "; units where the ΔT terms help: "
            f"{_n_of(int(r['units method better']), int(r['n units']))}"
        )
    if not design.empty:
        c, k = design["soak_rate_grad_corr"], design["soak_design_cond"]
        out.append(
            f"The soak design of the {len(design)} calibrated unit(s): Ṫ and ΔT correlate at "
            f"r = {_sg(c.median())} (median; {_sg(c.min())} to {_sg(c.max())}), and the "
            f"design of the three inputs alone, [T, Ṫ, ΔT] each standardised, has condition "
            f"number {k.median():.1f} ({k.min():.1f} to {k.max():.1f}; 1 for independent "
            "columns; not the condition number of method 2's whole polynomial design, whose "
            "powers of one input make it far larger)"
            + (
                "; the units share one thermal network and soak protocol, so their designs "
                "differ only by the thermometers' noise. "
                if c.max() - c.min() < 0.02
                else ". "
            )
            + (
                "The two move together closely: the data can hardly tell a Ṫ term from a "
                "ΔT term, so what the ΔT terms add is weakly determined."
                if abs(c.median()) > 0.8
                else "They are separable enough to fit both terms."
            )
        )
    return out


def map_lines(cells: pd.DataFrame) -> list[str]:
    """The map's reading: per method and reference, in how many cells it is resolved
    better, worse, unresolved or has no interval."""
    out = []
    for (m, ref), g in cells.groupby(["method", "reference"], sort=False):
        k = g["cell"].value_counts()
        name = "no compensation" if ref == "none" else "the cubic in T"
        out.append(
            f"sensitivity map, {short_label(m)} against {name}: better in "
            f"{_n_of(int(k.get('better', 0)), len(g))} cells, worse in "
            f"{int(k.get('worse', 0))}, not resolved in {int(k.get('unresolved', 0))}, no "
            f"interval (fewer than {MIN_N} units) in {int(k.get('not enough units', 0))}"
        )
    return out


def _num(v: float, nd: int) -> str:
    return "" if not math.isfinite(v) else f"{v:.{nd}f}".replace("-", "−")


#: Short names of the variants in the tables (the legend is :data:`CODES_LEGEND`).
CODES = {
    "none": "none",
    "poly-t": "cubic",
    "sectional": "m1",
    "regression": "m2",
    "regression-no-dT": "m2 w/o ΔT",
    "regression+sf": "m2+sf",
    "neural": "m3",
    "field": "field",
    "true": "oracle",
}
#: What each short name means, in :data:`CODES`' order.
_MEANINGS = {
    "none": "no compensation",
    "poly-t": "the cubic in T (baseline)",
    "sectional": "the paper's method 1 (sectional)",
    "regression": "the paper's method 2 (regression)",
    "regression-no-dT": "method 2 without its ΔT terms",
    "regression+sf": "method 2 behind the unit's scale-factor/axis calibration",
    "neural": "the paper's method 3 (BP network)",
    "field": "calibrated from the unit's own parked cold starts, no chamber",
    "true": "the true thermal bias",
}


def codes_legend(variants: Iterable[str] | None = None) -> str:
    """What the short names of ``variants`` mean, in one sentence: only those the study ran
    (every one without ``variants``)."""
    ran = set(CODES) if variants is None else set(variants)
    parts = [f"{CODES[v]}: {_MEANINGS[v]}" for v in CODES if v in ran]
    return "; ".join(parts) + "." if parts else ""


#: What every short name means (:func:`codes_legend` of every variant).
CODES_LEGEND = codes_legend()


def code(v: str) -> str:
    """A variant's short name in tables (:data:`CODES`)."""
    return CODES.get(v, v)


def short_verdict(n: int, verdict: str) -> str:
    """A verdict of the one rule (:mod:`rinscal.experiments.verdict`) as a table shows it:
    itself, or why there is none."""
    return too_few(n, "units") if verdict == TOO_FEW else verdict


def _where(label: str, scen: str) -> str:
    return f"{label} · {scen}"


def summary_view(summary: pd.DataFrame, metric: str) -> pd.DataFrame:
    """A metric's summary: mean with its interval (or why there is none), median, range."""
    s = summary[summary["metric"] == metric]
    nd = {"nmi": 3, "ug": 2, "dph": 5, "pct": 1}.get(metric.rsplit("_", 1)[-1], 0)
    unit = s["unit"].iloc[0] if not s.empty else ""
    return pd.DataFrame(
        {
            "plant · scenario": [
                _where(p, c) for p, c in zip(s["plant_label"], s["scenario"], strict=True)
            ],
            "method": [code(v) for v in s["variant"]],
            "units (runs)": [f"{u} ({r})" for u, r in zip(s["n units"], s["n runs"], strict=True)],
            f"mean [{unit}]": [_num(m, nd) for m in s["mean"]],
            f"{CONFIDENCE:.0%} interval [{unit}]": [
                fmt_interval(lo, hi, nd) or too_few(int(n), "units")
                for lo, hi, n in zip(s["ci low"], s["ci high"], s["n units"], strict=True)
            ],
            f"median [{unit}]": [_num(m, nd) for m in s["median"]],
            f"range [{unit}]": [
                f"{_num(a, nd)} – {_num(b, nd)}" for a, b in zip(s["min"], s["max"], strict=True)
            ],
        }
    )


def comparison_view(comp: pd.DataFrame, nd: int = 3) -> pd.DataFrame:
    """Each comparison as shown: Δ method − reference [nmi] with its interval in its own
    column, the ratio of medians, the count of units where the method is better, the
    verdict (short names, :data:`CODES`)."""
    return pd.DataFrame(
        {
            "plant · scenario": [
                _where(p, c) for p, c in zip(comp["plant_label"], comp["scenario"], strict=True)
            ],
            "method − ref.": [
                f"{code(m)} − {code(r)}"
                for m, r in zip(comp["method"], comp["reference"], strict=True)
            ],
            "Δ [nmi]": [_num(d, nd) for d in comp["delta"]],
            f"{CONFIDENCE:.0%} interval [nmi]": [
                fmt_interval(lo, hi, nd)
                for lo, hi in zip(comp["delta ci low"], comp["delta ci high"], strict=True)
            ],
            "median ratio": [_num(x, 2) for x in comp["median ratio"]],
            "units better": [
                _n_of(int(k), int(n))
                for k, n in zip(comp["units method better"], comp["n units"], strict=True)
            ],
            "verdict: method better": [
                short_verdict(int(n), v)
                for n, v in zip(comp["n units"], comp["verdict"], strict=True)
            ],
        }
    )


def pairs_view(pairs: pd.DataFrame) -> pd.DataFrame:
    """Every pair a → b: a − b [nmi] with its interval, counts of units and runs where b is
    better, the best single run [%]."""
    p = pairs[pairs["metric"] == "max_error_nmi"]
    return pd.DataFrame(
        {
            "plant · scenario": [
                _where(a, c) for a, c in zip(p["plant_label"], p["scenario"], strict=True)
            ],
            "a → b": [f"{code(a)} → {code(b)}" for a, b in zip(p["a"], p["b"], strict=True)],
            "a − b [nmi]": [_num(d, 3) for d in p["difference"]],
            f"{CONFIDENCE:.0%} interval [nmi]": [
                fmt_interval(lo, hi, 3)
                for lo, hi in zip(p["diff ci low"], p["diff ci high"], strict=True)
            ],
            "b better: units": [
                _n_of(int(k), int(n))
                for k, n in zip(p["units b better"], p["n units"], strict=True)
            ],
            "b better: runs": [
                _n_of(int(k), int(n)) for k, n in zip(p["runs b better"], p["n runs"], strict=True)
            ],
            "best run [%]": [_num(x, 0) for x in p["best decrease over the runs %"]],
        }
    )


def claims_view(claims: pd.DataFrame) -> pd.DataFrame:
    """The paper's claims as shown (7 columns): the claim where it was tested, the paper's
    figure, our change of the mean error (a description), the paired difference method −
    reference [nmi] with its interval, the count of units where the method is better, the
    verdict of the one rule."""
    n = claims["n units"].astype(int)
    return pd.DataFrame(
        {
            "claim (plant · scenario)": [
                f"{c} ({_where(p, s)})"
                for c, p, s in zip(
                    claims["claim"], claims["plant"], claims["scenario"], strict=True
                )
            ],
            "paper": claims["paper"],
            "ours: mean error": claims["ours: change"],
            f"Δ [nmi], {CONFIDENCE:.0%} interval": [
                _num(d, 2) + (f" {fmt_interval(lo, hi, 2)}" if math.isfinite(lo) else "")
                for d, lo, hi in zip(
                    claims["mean_nmi"], claims["ci_low_nmi"], claims["ci_high_nmi"], strict=True
                )
            ],
            "best run [%]": [_num(x, 0) for x in claims["ours: best run %"]],
            "method better": [
                _n_of(int(k), int(m)) for k, m in zip(claims["units b better"], n, strict=True)
            ],
            "verdict": [
                short_verdict(int(k), v) for k, v in zip(n, claims["verdict"], strict=True)
            ],
        }
    )


def map_view(cells: pd.DataFrame) -> pd.DataFrame:
    """The map's cells as a narrow table: a row per plant variant (``#`` index of the
    plants table), warm-up time and method, the difference against no compensation and
    against the cubic in T [nmi] with their intervals, and the cells' verdicts."""
    rows = []
    key = ["plant", "warm-up [min]", "method"]
    for (plant, warm, m), g in cells.groupby(key, sort=False):
        row: list[Any] = [f"#{plant}", f"{warm:g}", code(m)]
        verdict = []
        for ref in ("none", "poly-t"):
            r = g[g["reference"] == ref]
            if r.empty:
                row += ["", ""]
                continue
            r = r.iloc[0]
            row += [_num(r["delta"], 2), fmt_interval(r["delta ci low"], r["delta ci high"], 2)]
            verdict.append(f"{r['cell']} vs {code(ref)}")
        n = int(g["n units"].max())
        row.append(
            too_few(n, "units") if all("not enough" in v for v in verdict) else "; ".join(verdict)
        )
        rows.append(row)
    interval = f"{CONFIDENCE:.0%} interval"
    cols = ["plant", "warm-up [min]", "method", "− none [nmi]", interval, "− cubic [nmi]"]
    return pd.DataFrame(rows, columns=[*cols, interval, "verdict"])


def sensitivities_view(sens: pd.DataFrame) -> pd.DataFrame:
    """The plant variants with their equivalent sensitivities and sweep factors."""
    return pd.DataFrame(
        {
            "plant": [f"#{p}" for p in sens["plant"]],
            "law": sens["law"],
            "accel Ṫ [µg per °C/min]": [f"{x:.3g}" for x in sens["accel_rate_ug_per_c_min"]],
            "accel ΔT [µg/°C]": [f"{x:.3g}" for x in sens["accel_grad_ug_per_c"]],
            "gyro Ṫ [°/h per °C/min]": [f"{x:.2g}" for x in sens["gyro_rate_dph_per_c_min"]],
            "from": [x.replace(" on the soak protocol", " (soak)") for x in sens["source"]],
            "sweep": [
                label.split(" ", 1)[1] if " " in label else "" for label in sens["plant_label"]
            ],
        }
    )


def design_view(design: pd.DataFrame) -> pd.DataFrame:
    """Each unit's soak design: the correlation of Ṫ and ΔT, the condition number."""
    return pd.DataFrame(
        {
            "plant": design["plant_label"],
            "unit": design["unit"],
            "corr(Ṫ, ΔT)": [f"{x:+.2f}".replace("-", "−") for x in design["soak_rate_grad_corr"]],
            "condition number": [f"{x:.1f}" for x in design["soak_design_cond"]],
        }
    )


def ul(items: list[str]) -> str:
    """An HTML list of sentences (escaped)."""
    return "<ul>" + "".join(f"<li>{html.escape(x)}</li>" for x in items) + "</ul>"
