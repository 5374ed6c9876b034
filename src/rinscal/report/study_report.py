"""The report of a study: ``report.html`` (self-contained), ``tables/*.csv``,
``summary.json``.

Everything is computed from the results folder (:class:`rinscal.experiments.study.runner.
StudyStore`) by :mod:`rinscal.experiments.study.stats`, :mod:`~rinscal.experiments.study.
compare` and :mod:`~rinscal.experiments.study.sensitivity`; this module only lays the numbers
out and words them. The report can be rebuilt from the folder at any time, and a resumed
study's report covers every task that ever finished. Figures are in
:mod:`rinscal.report.study_figures`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rinscal._version import __version__
from rinscal.experiments.study.compare import (
    FIELD_VARIANT,
    NO_DT_VARIANT,
    design_table,
    fmt_interval,
    paired_against,
    study_claims,
)
from rinscal.experiments.study.runner import RunSummary, StudyStore
from rinscal.experiments.study.sensitivity import (
    OPERATING_POINT_C,
    plant_sensitivities,
    sensitivity_map,
)
from rinscal.experiments.study.spec import StudySpec, plant_table, sweep_columns
from rinscal.experiments.study.stats import (
    claims_table,
    method_summary,
    paired_differences,
    structure_findings,
    structure_pairs,
    uncompensated_wins,
)
from rinscal.experiments.verdict import CONFIDENCE, MIN_N, RULE, too_few
from rinscal.io.atomic import write_atomic
from rinscal.report.html import Report, figure_to_png
from rinscal.report.study_figures import (
    COLORS,
    distribution_figure,
    map_figure,
    paired_figure,
)
from rinscal.report.study_words import (
    ablation_lines,
    claims_view,
    codes_legend,
    comparison_view,
    design_view,
    field_lines,
    map_lines,
    map_view,
    oracle_lines,
    pairs_view,
    sensitivities_view,
    summary_view,
    ul,
)
from rinscal.report.verdict_view import (
    claims_lines,
    verdict_paragraph,
    verdict_table,
    write_claims_csv,
)

__all__ = [
    "COLORS",
    "StudyTables",
    "WrittenStudy",
    "build_report",
    "claims_view",
    "comparison_view",
    "map_view",
    "study_tables",
    "tables_from_results",
    "verdict_lines",
    "write_study_report",
]


def _empty() -> pd.DataFrame:
    return pd.DataFrame()


@dataclass
class StudyTables:
    """Every table of a study's report.

    ``comparisons``: each method against no compensation and the cubic in T
    (:func:`rinscal.experiments.study.compare.paired_against`); ``oracle``: no compensation
    against the oracle; ``ablation``: method 2 against method 2 without ``ΔT``; ``field_cal``: the
    field calibration against the chamber's method 2 and no compensation; ``design``:
    each unit's soak design; ``sensitivities``: each plant variant's equivalent sensitivities;
    ``sensitivity``: the map's cells; ``claim_rows``: the claims of ``claims.csv`` under the
    one rule (:func:`rinscal.experiments.study.compare.study_claims`).
    """

    results: pd.DataFrame
    plants: pd.DataFrame
    summary: pd.DataFrame
    pairs: pd.DataFrame
    claims: pd.DataFrame
    sensitivity: pd.DataFrame
    failures: pd.DataFrame
    uncompensated: list[str] = field(default_factory=list)
    structure: list[str] = field(default_factory=list)
    comparisons: pd.DataFrame = field(default_factory=_empty)
    oracle: pd.DataFrame = field(default_factory=_empty)
    ablation: pd.DataFrame = field(default_factory=_empty)
    field_cal: pd.DataFrame = field(default_factory=_empty)
    design: pd.DataFrame = field(default_factory=_empty)
    sensitivities: pd.DataFrame = field(default_factory=_empty)
    claim_rows: pd.DataFrame = field(default_factory=_empty)


@dataclass
class WrittenStudy:
    """What :func:`write_study_report` wrote, and the verdicts in words."""

    report: Path
    tables: StudyTables
    verdicts: list[str]


def tables_from_results(
    results: pd.DataFrame,
    plants: pd.DataFrame,
    failures: pd.DataFrame | None = None,
    sensitivities: pd.DataFrame | None = None,
) -> StudyTables:
    """Every statistic of a results frame (``sensitivities``: the plants'
    :func:`rinscal.experiments.study.sensitivity.plant_sensitivities`, for a sweep)."""
    failures = pd.DataFrame(columns=["task", "error"]) if failures is None else failures
    if results.empty:
        e = _empty()
        return StudyTables(results, plants, e, e, e, e, failures)
    pairs = paired_differences(results)
    claims = claims_table(results, pairs)
    summary = method_summary(results)
    comp = paired_against(results, ("none", "poly-t"))
    sens = sensitivities if sensitivities is not None else _empty()
    return StudyTables(
        results=results,
        plants=plants,
        summary=summary,
        pairs=pairs,
        claims=claims,
        sensitivity=sensitivity_map(comp, sens) if not sens.empty else _empty(),
        failures=failures,
        uncompensated=uncompensated_wins(pairs),
        structure=structure_findings(claims, summary, plants, pairs),
        comparisons=comp,
        oracle=paired_against(results, ("true",), ("none",)),
        ablation=paired_against(results, (NO_DT_VARIANT,), ("regression",)),
        field_cal=paired_against(results, ("regression", "none"), (FIELD_VARIANT,)),
        design=design_table(results),
        sensitivities=sens,
        claim_rows=study_claims(results),
    )


def study_tables(store: StudyStore, spec: StudySpec) -> StudyTables:
    """The statistics of every finished task of ``spec`` in ``store``."""
    results = store.read_results(spec)
    plants = plant_table(spec)
    sens = plant_sensitivities(spec) if sweep_columns(spec) and not results.empty else None
    return tables_from_results(results, plants, store.failures(), sens)


def verdict_lines(t: StudyTables) -> list[str]:
    """The findings in words: each claim's verdict under the one rule (the paper's
    comparisons, every method against no compensation and the cubic in T), where no
    compensation wins, the oracle, the ΔT ablation, the
    structure findings and the sensitivity map's reading."""
    out = claims_lines(t.claim_rows, "units") if not t.claim_rows.empty else []
    out.extend(t.uncompensated)
    if not t.oracle.empty:
        out += oracle_lines(t.oracle)
    if not t.ablation.empty:
        out += ablation_lines(t.ablation, t.design)
    if not t.field_cal.empty:
        out += field_lines(t.field_cal)
    out.extend(t.structure)
    if not t.sensitivity.empty:
        out += map_lines(t.sensitivity)
    return out


# --------------------------------------------------------------------------- the report
def build_report(spec: StudySpec, t: StudyTables, run: RunSummary | None) -> Report:
    """The HTML report of a study from its tables."""
    rep = Report(
        f"rinscal study: {spec.name}",
        f"rinscal {__version__} · {spec.units} unit(s) · seed {spec.seed}"
        + (" · quick sizes" if spec.quick else "")
        + " · every figure a simulation",
    )
    if not t.results.empty:
        _verdict_section(rep, t)
    _what_ran(rep, spec, t, run)
    if t.results.empty:
        return rep
    n_units = int(t.results["unit"].nunique())
    if not t.comparisons.empty:
        c = rep.section("Every method against no compensation and the cubic in T", "against")
        c.text(
            "Each method's maximum position error minus that of the reference, paired on the "
            "same raw output of each cold start, averaged over a unit's starts, then over "
            f"units (Δ < 0: the method has less error), with a {CONFIDENCE:.0%} Student-t "
            "interval over units. The ratio of medians is the median over units of the "
            "method's error over the median of the reference's (a description). The verdict "
            "is on 'method better than reference': holds only where the interval lies below "
            "zero, reversed where above."
            + (
                f" This study has {n_units} unit(s): {too_few(n_units, 'units')}, so the "
                "interval column is empty and no difference is decided."
                if n_units < MIN_N
                else ""
            )
        )
        for p in _shown(t):
            c.figure(
                f"paired-p{p}",
                figure_to_png(paired_figure(t.comparisons, p)),
                "Paired difference method − reference of the maximum position error [nmi]",
            )
        if t.sensitivity.empty:
            c.text(codes_legend(_variants(t)), "note")
            c.table(
                "against",
                comparison_view(t.comparisons),
                "Every method against no compensation and the cubic in T (Δ = method − "
                "reference; negative: the method has less error)",
            )
        else:
            c.text(
                f"The {len(t.comparisons)} comparisons of this sweep are in "
                "tables/against_references.csv; the sensitivity map below shows those of "
                "methods 2 and 3.",
                "note",
            )
    if not t.claims.empty:
        cl = rep.section("The paper's claims", "claims")
        cl.text(
            "Each claim of the paper's Section 5 beside the paper's figure: the paired "
            "difference method − reference [nmi] with its interval over units decides ("
            + RULE
            + "). The change of the mean error and the best single run only describe; the "
            "paper's lab figures are its best run ('up to')."
        )
        cl.table(
            "claims", claims_view(t.claims), "The paper's claims with our interval and verdict"
        )
    if not t.oracle.empty:
        _oracle_section(rep, t)
    if not t.ablation.empty:
        _ablation_section(rep, t)
    if not t.field_cal.empty:
        _field_section(rep, t)
    if t.structure:
        st = rep.section("Does the verdict survive a change of thermal law?", "structure")
        st.text(
            "The study ran plants that differ only in their thermal law: "
            + "; ".join(
                f"{a['plant_label']} (polynomial) and {b['plant_label']} (mechanistic)"
                for a, b in structure_pairs(t.plants)
            )
            + ". The polynomial law is, term for term, the paper's method-2 regression, so a "
            "verdict for method 2 on it partly measures the plant's own shape; the mechanistic "
            "law drives each bias by nodes of the thermal network that no thermometer sees "
            "(the electronics box through a lag, the box-to-mount gradient, the package "
            "stress, a saturating own temperature), which no model class here represents. "
            "A finding that holds on both is one the plant's shape did not decide."
        )
        st.raw(ul(t.structure))
    if "accel_residual_pct" in set(t.summary.get("metric", [])):
        _residual_section(rep, t)
    if t.uncompensated:
        u = rep.section("Where no compensation wins", "uncompensated")
        u.text(
            "Plants, scenarios and methods whose mean error is above no compensation's, with "
            "the paired difference and its verdict: only a resolved verdict says that "
            "compensating with the method makes navigation worse."
        )
        u.raw(ul(t.uncompensated))
    _distributions_section(rep, t)
    pr = rep.section("Every pair of methods", "paired")
    pr.text(
        "Every pair a → b, paired as above (a − b > 0: b has less error), with the count of "
        "units and of single runs where b is better. 'Best run' is the largest single-run "
        "decrease from a to b [%], the paper's 'up to' figure: a maximum, not an estimate."
    )
    if t.sensitivity.empty:
        pr.text(codes_legend(_variants(t)), "note")
        pr.table(
            "pairs",
            pairs_view(t.pairs),
            "Paired differences of the maximum position error",
            fold=True,
        )
    else:
        pr.text(f"The {len(t.pairs)} pairs of this sweep are in tables/paired_differences.csv.")
    if not t.sensitivity.empty:
        _map_section(rep, t)
    if not t.failures.empty:
        f = rep.section("Failed tasks", "failures")
        f.text(
            f"{len(t.failures)} task(s) raised; the statistics leave them out. Run the "
            "study again with --retry-failed to retry them.",
            "banner",
        )
        f.table("failures", t.failures, "Tasks that raised and their errors")
    return rep


def _verdict_section(rep: Report, t: StudyTables) -> None:
    """The verdict that opens the report: per plant and scenario, each method's mean
    maximum position error over units with its interval and its verdict against method
    1, no compensation and the cubic in T; then one paragraph."""
    s = t.summary[t.summary["metric"] == "max_error_nmi"]
    means = pd.DataFrame(
        {
            "plant": s["plant_label"],
            "group": s["scenario"],
            "method": s["variant"],
            "n": s["n units"],
            "mean": s["mean"],
            "lo": s["ci low"],
            "hi": s["ci high"],
        }
    )
    v = rep.section(
        "Verdict: each method against method 1, none and the cubic", "verdict", lead=True
    )
    v.table(
        "verdict",
        verdict_table(means, t.claim_rows, "units"),
        "Maximum position error per plant and scenario [nmi], mean over units, and the "
        "verdict on 'method better than' each reference (paired mean difference method − "
        "reference [nmi])",
    )
    v.text(verdict_paragraph(t.claim_rows, "units"))


def _variants(t: StudyTables) -> set[str]:
    """The variants the study navigated (the legend explains only those)."""
    return set(t.results["variant"]) if "variant" in t.results else set()


def _shown(t: StudyTables) -> list[Any]:
    plants = list(dict.fromkeys(t.results["plant"]))
    return plants if len(plants) <= 2 else plants[:1]


def _what_ran(rep: Report, spec: StudySpec, t: StudyTables, run: RunSummary | None) -> None:
    s = rep.section("What ran", "what")
    s.text(spec.description or spec.name)
    n_runs = t.results.drop_duplicates(["plant", "unit", "scenario", "start"]).shape[0]
    s.text(
        f"{len(spec.plants)} plant variant(s), {spec.units} unit(s) each (unit-to-unit spread "
        f"of the thermal coefficients {spec.coefficient_spread:.0%}, 1σ), each unit calibrated "
        f"on its own soak runs ({spec.calibration.hours:g} h per run at "
        f"{spec.calibration.rate_hz:g} Hz)"
        + (
            f" and, for the field variant, from {spec.calibration.field_runs} of its own "
            f"parked cold starts ({spec.calibration.field_hours:g} h at "
            f"{spec.calibration.field_rate_hz:g} Hz, ambients "
            + ", ".join(f"{a:g}" for a in spec.calibration.field_ambient_c)
            + " °C)"
            if FIELD_VARIANT in spec.methods
            else ""
        )
        + " and navigated in "
        + ", ".join(
            f"{sc.name} ({len(sc.ambient_c)} start(s), {sc.hours:g} h at {sc.rate_hz:g} Hz, "
            f"alignment {sc.align_s:g} s from {sc.align_start_s:g} s)"
            for sc in spec.scenarios
        )
        + f". {n_runs} navigation run(s) have finished; every method navigated on the same "
        "raw output of each run."
    )
    if run is not None:
        s.text(
            f"This invocation computed {run.computed} task(s) ({run.skipped} were already done) "
            f"on {run.workers} worker(s) in {run.wall_s:.0f} s; {run.failed} task(s) failed.",
            "note",
        )
    s.text(
        "The units are the independent draws: a comparison is paired within a run (both "
        "methods on the same raw output), averaged over a unit's starts (they share its "
        f"calibration), and given a {CONFIDENCE:.0%} Student-t interval over units, for "
        "means and differences in nmi alike. " + RULE + " Counts are "
        "counts ('2 of 3'). 'Best run' columns are maxima over single runs, the paper's 'up "
        "to' figures; they are not estimates.",
        "note",
    )
    if t.results.empty:
        s.text("No navigation task has finished yet.", "banner")


def _oracle_section(rep: Report, t: StudyTables) -> None:
    o = rep.section("The oracle and the thermal part", "oracle")
    o.text(
        "The oracle navigates the same raw output compensated with the plant's true thermal "
        "bias: the best any thermal model could do. A variant's thermal part (variant − "
        "oracle, the 'thermal part' table below) is then the position error its model error "
        "alone causes; turn-on offsets, noise and the alignment are common to both and "
        "cancel. In a single run the oracle can still lose to no compensation: the thermal "
        "bias and the run's turn-on offsets and noise add up to heading and tilt errors that "
        "can partly cancel, and removing only the thermal part can undo a lucky "
        "cancellation. Over units such luck averages out, so the test of the oracle is the "
        "paired comparison below: no compensation − oracle > 0 means the oracle has less "
        "error."
    )
    o.raw(ul(oracle_lines(t.oracle)))
    o.table(
        "oracle",
        comparison_view(t.oracle),
        "No compensation against the oracle (Δ = none − oracle; positive: the oracle has "
        "less error)",
    )


def _ablation_section(rep: Report, t: StudyTables) -> None:
    a = rep.section("Does the gradient pay? Method 2 with and without ΔT", "ablation")
    a.text(
        "Method 2 refitted on each unit's soak runs with its ΔT terms dropped (T and Ṫ only, "
        "the same orders) and navigated on the same raw output: the paired difference "
        "method 2 − method 2 without ΔT (< 0: the gradient terms help) answers whether the "
        "gradient pays apart from the temperature rate. Whether a fit can separate the two "
        "depends on the soak design: the correlation of Ṫ and ΔT over the unit's soak runs "
        "(horizontal accelerometers, the worse of x and y) and the condition number of the "
        "standardised design [T, Ṫ, ΔT]."
    )
    a.raw(ul(ablation_lines(t.ablation, t.design)))
    a.table(
        "ablation",
        comparison_view(t.ablation),
        "Method 2 against method 2 without ΔT (Δ = with − without)",
    )
    if not t.design.empty:
        a.table("design", design_view(t.design), "Each unit's soak design", fold=True)


def _field_section(rep: Report, t: StudyTables) -> None:
    a = rep.section("Without a chamber: calibrated from parked cold starts", "field")
    a.text(
        "Each unit calibrated a second time, with no chamber: from its own parked cold "
        "starts (the table indexing, the biases estimated on the static base, then fitted "
        "as fit does; rinscal.calibrate_field), and navigated on the same raw output as the "
        "chamber's method 2 and no compensation. The navigation starts are held out from "
        "both calibrations. The mean ratio is each start's maximum position error with the "
        "field model over method 2's (or no compensation's), averaged over a unit's starts, "
        f"then over units, with its {CONFIDENCE:.0%} Student-t interval over units (a "
        "description); the verdict is the one rule's on the paired difference."
    )
    a.raw(ul(field_lines(t.field_cal)))
    view = comparison_view(t.field_cal)
    view.insert(
        4,
        "mean ratio",
        [
            f"{r:.2f} {fmt_interval(lo, hi, 2)}".strip()
            for r, lo, hi in zip(
                t.field_cal["mean ratio"],
                t.field_cal["mean ratio ci low"],
                t.field_cal["mean ratio ci high"],
                strict=True,
            )
        ],
    )
    a.table(
        "field",
        view,
        "The field calibration against the chamber's method 2 and no compensation (Δ = field "
        "− reference)",
    )


def _residual_section(rep: Report, t: StudyTables) -> None:
    h = rep.section("How much of each result is model error", "residual")
    h.text(
        "Each model's held-out thermal residual on the cold starts themselves (not the "
        "soak runs it was fitted to): the RMS of (model − true thermal bias) about its "
        "mean over the run, from the alignment start, as a share of the true bias's own "
        "swing (the worse horizontal accelerometer), and in µg and °/h. The mean is left "
        "out because the alignment absorbs a constant bias; it reappears as heading error "
        "(the |heading error| table). A model with a small residual and a large position "
        "error owes its error to the alignment and the noise, not to the model."
    )
    for metric, caption in (
        ("accel_residual_pct", "Horizontal accelerometers: share of the thermal swing left"),
        ("accel_residual_ug", "Horizontal accelerometers: residual RMS"),
        ("gyro_residual_dph", "Gyros: residual RMS, worst axis"),
    ):
        h.table(f"summary_{metric}", summary_view(t.summary, metric), caption, fold=True)


def _distributions_section(rep: Report, t: StudyTables) -> None:
    d = rep.section("Distributions per method", "distributions")
    shown = _shown(t)
    for p in shown:
        d.figure(
            f"distribution-p{p}",
            figure_to_png(distribution_figure(t.results, p)),
            "Maximum horizontal position error of every run, per method and scenario",
        )
    n_plants = t.results["plant"].nunique()
    if len(shown) < n_plants:
        d.text(
            f"Figures for the first plant variant only; {n_plants} variants are in the "
            "tables and the sensitivity map.",
            "note",
        )
    d.table(
        "summary_max_error",
        summary_view(t.summary, "max_error_nmi"),
        "Maximum horizontal position error per run",
        fold=True,
    )
    d.text(
        "The thermal part of a run is the largest distance between the variant's and the "
        "oracle's position error tracks (same raw output): the error the model's misfit "
        "alone causes. It is not the variant's error minus the oracle's error, and it is "
        "positive even where the variant's total error is below the oracle's (see 'The "
        "oracle and the thermal part')."
    )
    d.table(
        "summary_thermal_part",
        summary_view(t.summary, "thermal_part_nmi"),
        "Its thermal part: the variant's position error track minus the oracle's",
        fold=True,
    )
    d.table(
        "summary_heading",
        summary_view(t.summary, "abs_heading_error_arcsec"),
        "|heading error| at the start of free navigation",
        fold=True,
    )


def _map_section(rep: Report, t: StudyTables) -> None:
    m = rep.section("Sensitivity map", "sensitivity")
    m.text(
        "Where do methods 2 and 3 pay? Each cell is a method's maximum position error minus "
        "no compensation's or the cubic in T's (paired, mean over units, nmi) with its "
        f"{CONFIDENCE:.0%} interval; a cell is coloured only where the interval excludes "
        "zero. The plant variants are placed by their equivalent thermal sensitivities: the "
        "horizontal accelerometers' bias per temperature rate (µg per °C/min) and per "
        "inside/outside gradient (µg/°C), the gyros' bias per temperature rate (°/h per "
        "°C/min), mean magnitudes over the horizontal accelerometers and over the gyros. For "
        f"the polynomial law they are the slopes of the plant's law at {OPERATING_POINT_C:g} "
        "°C, Ṫ = 0, ΔT = 0 (its coefficients times the sweep factors); for the mechanistic "
        "law, which has no such coefficients, the coefficients of a first-order Table-6 "
        "regression fitted to its true thermal bias over the soak protocol. Panels: one per "
        "thermal law and warm-up time (the alignment's start after power-on)."
    )
    m.raw(ul(map_lines(t.sensitivity)))
    m.figure("sensitivity-map", figure_to_png(map_figure(t.sensitivity)), "The sensitivity map")
    m.table(
        "sensitivity_plants",
        sensitivities_view(t.sensitivities),
        "The plant variants: equivalent sensitivities",
        fold=True,
    )
    m.table("sensitivity", map_view(t.sensitivity), "The sensitivity map as a table", fold=True)


def write_study_report(
    store: StudyStore, spec: StudySpec, run: RunSummary | None = None
) -> WrittenStudy:
    """Write ``report.html``, ``tables/*.csv`` and ``summary.json`` into the study's folder."""
    t = study_tables(store, spec)
    root = store.root
    (root / "tables").mkdir(parents=True, exist_ok=True)
    named = {
        "results": t.results,
        "plants": t.plants,
        "method_summary": t.summary,
        "paired_differences": t.pairs,
        "against_references": t.comparisons,
        "oracle": t.oracle,
        "gradient_ablation": t.ablation,
        "field_calibration": t.field_cal,
        "soak_design": t.design,
        "paper_claims": t.claims,
        "plant_sensitivities": t.sensitivities,
        "sensitivity_map": t.sensitivity,
        "failures": t.failures,
    }
    for name, df in named.items():
        write_atomic(
            root / "tables" / f"{name}.csv", lambda tmp, df=df: df.to_csv(tmp, index=False)
        )
    verdicts = verdict_lines(t)
    summary: dict[str, Any] = {
        "study": spec.name,
        "rinscal": __version__,
        "units": spec.units,
        "navigation_runs": int(
            t.results.drop_duplicates(["plant", "unit", "scenario", "start"]).shape[0]
        )
        if not t.results.empty
        else 0,
        "failed_tasks": len(t.failures),
        "verdicts": verdicts,
        "structure": t.structure,
        "claims": t.claims.to_dict(orient="records"),
        "verdicts_nmi": t.claim_rows.to_dict(orient="records"),
    }
    if run is not None:
        secs = {k: v for k, v in run.task_seconds.items() if v}
        summary["run"] = {
            "computed": run.computed,
            "skipped": run.skipped,
            "failed": run.failed,
            "workers": run.workers,
            "wall_s": run.wall_s,
            "peak_worker_mb": run.peak_mb,
            "mean_task_s": {k: float(np.mean(v)) for k, v in secs.items()},
        }
    text = json.dumps(summary, indent=1, allow_nan=True, default=str) + "\n"
    write_atomic(root / "summary.json", lambda tmp: tmp.write_text(text))
    page = build_report(spec, t, run).to_html()
    write_claims_csv(root / "claims.csv", t.claim_rows)
    write_atomic(root / "report.html", lambda tmp: tmp.write_text(page, encoding="utf-8"))
    return WrittenStudy(root / "report.html", t, verdicts)
