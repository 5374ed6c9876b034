"""Figures and the HTML report of ``rinscal reproduce`` (the paper's Section 5 side by side).

Every function takes the data the experiments returned and fills a report section or writes
the reproduction's files; nothing here computes a result. The figures are drawn in
:mod:`rinscal.report.paper_figures`.

Why one module: it is long because it is one idea: the reproduction's report, section by
section, with the words each section says from the numbers and the files it is written to.
"""

from __future__ import annotations

import html
import json
import shlex
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rinscal import units
from rinscal.experiments.paper.calibration import CalibrationResult
from rinscal.experiments.paper.claims import (
    NAV_GROUPS,
    PAPER_PAIRS,
    claims,
    decrease_pct,
    group_means,
    nav_group,
    nav_method_table,
    paired_claims,
    paired_table,
    selection_summary_table,
    summary_table,
    uncompensated_wins_heldout,
    uncompensated_wins_nav,
)
from rinscal.experiments.paper.config import (
    LABELS,
    METHODS,
    PAPER,
    VARIANTS,
    ReproConfig,
    load_plant,
    plant_info,
)
from rinscal.experiments.paper.imucal import IMU_VARIANT, paired_saving_table
from rinscal.experiments.paper.mechanism import (
    ORACLE_NO_OFFSETS,
    ORACLE_NO_OFFSETS_LABEL,
    mechanism_summary,
    mechanism_tables,
)
from rinscal.experiments.paper.navigation import (
    NavRunResult,
    heading_error_table,
    max_error_table,
    thermal_part_table,
    variant_table,
)
from rinscal.experiments.verdict import REVERSED, RULE, TOO_FEW
from rinscal.io.atomic import write_atomic
from rinscal.report.allan_plot import allan_figure
from rinscal.report.html import Report, figure_to_png
from rinscal.report.logplot import plot_log
from rinscal.report.paper_cal_sections import add_calibration_sections, imu_section
from rinscal.report.paper_figures import (
    fig_heading_velocity,
    fig_lab_bars,
    fig_nav_errors,
    fig_repeat,
    fig_selection,
    fig_temperatures,
    fig_vehicle_track,
)
from rinscal.report.paper_nav_sections import (
    MECHANISM_TABLES,
    nav_sections,
    run_table_view,
)
from rinscal.report.verdict_view import (
    claims_view,
    verdict_paragraph,
    verdict_table,
    write_claims_csv,
)

#: The sections that show their lead paragraph and fold the rest (the verdict and the
#: summary stay open): the quick report reads in at most 15 screens before its folds.
DETAIL_SECTIONS = (
    "calibration-data", "method1", "method2", "method3", "heldout", "table9", "ramp", "lab",
    "vehicle", "mechanism", "thermal-part", "imu-cal", "method",
)  # fmt: skip


def _verdict(ok: bool) -> str:
    return (
        '<span class="verdict-pass">holds</span>'
        if ok
        else '<span class="verdict-fail">does not hold</span>'
    )


# --------------------------------------------------------------------------- words
_LOG_WORDS = {"repeat": "the held-out repeat start", "ramp": "the held-out chamber ramp"}


def _join(items: Sequence[str]) -> str:
    items = list(items)
    if len(items) <= 1:
        return "".join(items)
    return ", ".join(items[:-1]) + " and " + items[-1]


def words_uncompensated_heldout(residual: pd.DataFrame, log: str) -> str:
    """One sentence, from the numbers, saying on which channels of a held-out log no
    compensation beats each method (or that every method beats it everywhere)."""
    where = _LOG_WORDS.get(log, f"the held-out run {log!r}")
    wins = uncompensated_wins_heldout(residual, log)
    if not wins:
        return (
            f"On {where}, every method has a smaller thermal residual than no compensation "
            "on every channel."
        )
    parts = [f"{LABELS[m]} on {_join(chans)}" for m, chans in wins.items()]
    return (
        f"On {where}, no compensation beats {'; '.join(parts)}: there the model's residual "
        "RMS is larger than the whole thermal variation it should remove, so compensating "
        "with it makes that output worse."
    )


def words_uncompensated_nav(maxerr: pd.DataFrame) -> str:
    """Sentences, from the numbers, saying where the uncompensated run has a smaller mean
    maximum position error than a method (or that every method beats it)."""
    wins = uncompensated_wins_nav(maxerr)
    if not wins:
        return (
            "In navigation, every method has a smaller mean maximum position error than no "
            "compensation, in every group of runs."
        )
    paired = paired_table(maxerr, "none", list(METHODS)).set_index(["runs", "variant"])
    out = []
    for group, exps, scen in NAV_GROUPS:
        if group not in wins:
            continue
        n = len(nav_group(maxerr, exps, scen))
        base = next(iter(wins[group].values()))[0]
        beaten = [f"{LABELS[m]} at {mm:.3f} nmi" for m, (_b, mm) in wins[group].items()]
        resolved = [LABELS[m] for m in wins[group] if paired.loc[(group, m), "verdict"] == REVERSED]
        verdicts = [str(paired.loc[(group, m), "verdict"]) for m in wins[group]]
        how = (
            "; too few runs for a paired interval"
            if any(v.startswith(TOO_FEW) for v in verdicts)
            else f"; paired run by run, the difference is resolved for {_join(resolved)} and "
            "not resolved for the rest (their intervals contain zero)"
            if resolved and len(resolved) < len(wins[group])
            else "; paired run by run, the difference is resolved (its interval excludes zero)"
            if resolved
            else "; paired run by run, the difference is not resolved (its interval contains zero)"
        )
        out.append(
            f"In navigation over the {group} runs (n = {n}), no compensation has a smaller "
            f"mean maximum position error ({base:.3f} nmi) than {_join(beaten)}{how}."
        )
    return " ".join(out)


def _max_words(r: NavRunResult, variants: Sequence[str] = VARIANTS) -> str:
    """'uncompensated 0.718, ... nmi; smallest among the models: X' for one run."""
    v = r.summary["variants"]
    vals = {k: float(v[k]["max_error_nmi"]) for k in variants if k in v}
    models = {k: x for k, x in vals.items() if k in METHODS}
    text = "maximum errors " + ", ".join(f"{LABELS[k]} {x:.3f}" for k, x in vals.items())
    if models:
        best = min(models, key=models.__getitem__)
        worst = max(models, key=models.__getitem__)
        text += f" nmi; smallest among the models: {LABELS[best]}, largest: {LABELS[worst]}"
        if "none" in vals:
            beaten = [LABELS[k] for k, x in models.items() if x > vals["none"]]
            if beaten:
                text += f"; no compensation beats {_join(beaten)} on this run"
    return text


def _ramp_domain_words(tables: Mapping[str, pd.DataFrame]) -> str:
    """Where the ramp's inputs leave the soak runs' domain (from
    :func:`rinscal.experiments.paper.paper_tables.ramp_outside_training`)."""
    if "ramp_outside_training" not in tables or tables["ramp_outside_training"].empty:
        return "the soak runs never see such gradients, so the models extrapolate."
    f = tables["ramp_outside_training"].iloc[0]
    each = ", ".join(
        f"{k} {100 * float(f[k]):.1f} %" for k in ("T", "Ṫ", "ΔT") if k in f and np.isfinite(f[k])
    )
    return (
        f"each input alone leaves the soak runs' range on few samples ({each}), but the "
        f"method-2 model flags {100 * float(f['flagged']):.0f} % of the ramp's samples as "
        "outside the joint (T, Ṫ, ΔT) domain of its training data, where a clamped model holds "
        "its edge instead of modelling: Figure 9 mostly tests that clamp."
    )


def _spread_view(nbm: pd.DataFrame, what: str, fmt: str) -> pd.DataFrame:
    """Rows: methods; columns: groups of runs; cells "mean ± sd (min to max)" of one
    quantity of :func:`rinscal.experiments.paper.claims.nav_method_table` (formatting
    only)."""
    col = {k: next(c for c in nbm.columns if c.startswith(f"{what} {k}")) for k in
           ("mean", "sd", "min", "max")}  # fmt: skip

    def cell(r: Any) -> str:
        if not np.isfinite(r[col["mean"]]):
            return ""
        sd = fmt.format(r[col["sd"]]) if np.isfinite(r[col["sd"]]) else "–"
        return (
            f"{fmt.format(r[col['mean']])} ± {sd} "
            f"({fmt.format(r[col['min']])} to {fmt.format(r[col['max']])})"
        )

    out = nbm.assign(cell=nbm.apply(cell, axis=1))
    groups = list(dict.fromkeys(out["runs"]))
    n = out.groupby("runs", sort=False)["n runs"].first()
    view = out.pivot(index="method", columns="runs", values="cell")
    view = view.reindex(index=list(dict.fromkeys(out["method"])), columns=groups)
    view.columns = [f"{g} (n = {int(n[g])})" for g in groups]
    return view.reset_index()


def _paired_words(tables: Mapping[str, pd.DataFrame]) -> str:
    """One sentence per reference: which methods are resolved better or worse over all
    the lab and vehicle runs."""
    out = []
    for ref, ident in (("none", "paired_vs_none"), ("poly-t", "paired_vs_poly_t")):
        t = tables[ident]
        t = t[(t["runs"] == "lab + vehicle") & (t["variant"] != "true")]
        if t.empty:
            continue
        better = [str(m) for m, v in zip(t["method"], t["verdict"], strict=True)
                  if v == "holds"]  # fmt: skip
        worse = [str(m) for m, v in zip(t["method"], t["verdict"], strict=True)
                 if v == REVERSED]  # fmt: skip
        n = int(t["n runs"].iloc[0])
        parts = []
        if better:
            parts.append(f"{_join(better)} beat{'s' if len(better) == 1 else ''} it")
        if worse:
            parts.append(f"{_join(worse)} {'is' if len(worse) == 1 else 'are'} worse than it")
        rest = len(t) - len(better) - len(worse)
        if rest:
            parts.append(f"{rest} method(s) show no resolved difference")
        out.append(
            f"Against {LABELS[ref]}, over all {n} lab and vehicle runs: " + "; ".join(parts) + "."
        )
    return " ".join(out)


def _plant_html(plant: Mapping[str, Any]) -> str:
    kind = "preset" if plant["kind"] == "preset" else "IMU file"
    others = " or ".join(f"<code>{html.escape(o)}</code>" for o in plant["run_other"])
    other = (
        f" To run the other built-in plant, add {others} to the command."
        if others
        else f" Built-in presets: {', '.join(plant['presets'])}."
    )
    return (
        f"Plant: <b>{html.escape(plant['name'])}</b> ({kind} "
        f"<code>{html.escape(plant['spec'])}</code>, chosen with "
        f"<code>--imu</code>).{other}"
    )


def build_report(
    cfg: ReproConfig,
    cal: CalibrationResult,
    nav: Sequence[NavRunResult],
    tables: Mapping[str, pd.DataFrame],
    claims: Mapping[str, Any],
    figures: Mapping[str, bytes],
    timings: Mapping[str, float],
    plant: Mapping[str, Any] | None = None,
    study: Any = None,
    out: Path | None = None,
) -> Report:
    """Assemble the report: every table and figure, the paper's numbers beside ours.

    ``plant`` is :func:`rinscal.experiments.paper.config.plant_info` of the IMU that ran (default:
    from ``cfg.imu`` and ``cal.imu``). ``study`` is the
    :class:`rinscal.report.study_report.StudyTables` of ``--units N`` (its report is in
    ``study/report.html``). ``out``: the output folder, named in the command the report
    gives.
    """
    if plant is None:
        plant = plant_info(cfg.imu, cal.imu or load_plant(cfg.imu))
    mode = "quick" if cfg.quick else "full"
    rep = Report(
        "rinscal: the paper's Section 5, reproduced in simulation",
        subtitle=(
            f"Wang, Cheng, Du, Sensors 2020. Mode {mode}, seed {cfg.seed}. Plant: "
            f"{plant['name']} (--imu {plant['spec']}). Every number of ours comes from "
            "that simulated plant; none is the paper's."
        ),
        folded=DETAIL_SECTIONS,
    )
    v = rep.section(
        f"Verdict on {plant['spec']}: each method against method 1, none and the cubic",
        "verdict",
        lead=True,
    )
    v.table(
        "verdict",
        tables["verdict"],
        "Maximum position error per group of runs [nmi], and the verdict on 'method better "
        "than' each reference (paired mean difference method − reference [nmi])",
    )
    v.text(verdict_paragraph(tables["claims"]))
    s = rep.section("Summary: the paper's numbers beside ours", "summary")
    s.raw(
        '<p class="banner">All of our figures are <b>simulation</b>: one simulated IMU plant '
        "on its turntable, soak-calibrated as in Table 3 and navigated as in Section 5.2; the "
        "calibration data and every navigation run come from the same plant. "
        + _plant_html(plant)
        + " No plant was tuned to agree with the paper. Where we disagree, the tables say "
        "so.</p>"
    )
    s.text(
        RULE + " The paper's own comparisons (method 1 → 2, 2 → 3, 1 → 3), paired run by "
        "run; every claim of the verdict table is in claims.csv beside this page."
    )
    s.table(
        "paired_paper",
        tables["paired_paper"],
        "The paper's own comparisons: method minus reference, paired over the runs of a group "
        "[nmi] (negative: the method has less error)",
    )
    items = []
    for c in claims.values():
        tag = "a test guards it" if c["asserted"] else "reported only"
        items.append(
            f"<li>{_verdict(c['holds'])} ({tag}): {_esc(c['what'])}: {_esc(_fmt_values(c))}</li>"
        )
    s.raw(
        "<h3>The paper's claims on held-out residuals [µg] (not in nmi, so not in claims.csv)"
        "</h3><ul>" + "".join(items) + "</ul>"
    )
    s.text(
        "The headline numbers, per run: our mean over the runs comes first with its spread "
        "(sample standard deviation, smallest and largest run, number of runs). The paper's "
        "percentages in its abstract and Section 5 are 'up to' figures, i.e. its best run: "
        "they stand in the column of maxima, beside our own largest run. Blank: the paper "
        "publishes no such figure."
    )
    s.table("summary", tables["summary"], "The paper's headline numbers and ours (per run)")
    h = tables["heldout_residual"]
    words = [words_uncompensated_heldout(h, log) for log in dict.fromkeys(h["log"])]
    words.append(words_uncompensated_nav(_maxerr_from(tables)))
    s.raw(
        "<h3>Where no compensation beats a model</h3><ul>"
        + "".join(f"<li>{_esc(w)}</li>" for w in words)
        + "</ul>"
    )
    nbm = tables["nav_by_method"]
    heading_known = bool(nbm["n heading"].sum() > 0)
    s.text(
        "Per method: the maximum horizontal position error of each run and the absolute "
        "heading error the alignment hands over at the start of free navigation, as mean, "
        "standard deviation, min and max over the runs. A heading error δψ at the start "
        "grows a position error of about R·Ω·cos(L)·δψ·t, so a model that biases the "
        "alignment shows up here before its drift does."
        + (
            ""
            if heading_known
            else " The heading error is blank: this version of the navigation summary does "
            "not report the attitude error at the start of navigation."
        )
    )
    s.table(
        "nav_by_method",
        _spread_view(nbm, "max error", "{:.3f}"),
        "Maximum position error [nmi] per method and group of runs: mean ± sd (min to max)",
    )
    s.table(
        "nav_heading_by_method",
        _spread_view(nbm, "|heading error|", "{:.0f}"),
        "|Heading error| at the start of free navigation [″] per method and group of runs: "
        "mean ± sd (min to max)",
    )
    s.text(
        "Paired: every variant of a run navigates the same raw output, so the difference of "
        "two variants on one run is free of that run's noise and turn-on offsets. Below, "
        "each method against no compensation and against the cubic in T: the mean "
        "difference of the maximum position error, method minus reference (negative: the "
        "method has less error), its 95 % Student-t interval over the runs, the runs "
        "where the method is better (a count), the change of the mean error (a description, "
        "not the test) and the verdict on 'method better than reference' under the rule "
        "above. " + _paired_words(tables)
    )
    for ref, ident in (("none", "paired_vs_none"), ("poly-t", "paired_vs_poly_t")):
        s.table(
            ident,
            tables[ident].drop(columns="variant"),
            f"Each variant against {LABELS[ref]}: the variant minus {LABELS[ref]}, paired "
            "over the runs of a group [nmi] (negative: the variant has less error)",
            formats={"Δ mean [nmi]": "{:+.3f}"},
        )
    s.table(
        "selection_vs_paper",
        tables["selection_vs_paper"],
        "Tables 5 and 7: training RMS, the paper's beside ours (units differ)",
        fold=True,
    )

    if study is not None and not study.claim_rows.empty:
        n = int(study.results["unit"].nunique())
        s = rep.section(f"Over {n} units: the claims with their intervals", "study")
        s.text(
            f"The navigation runs above come from one unit. Run as a study over {n} units "
            "(each calibrated on its own soak runs, thermal coefficients scattered from unit "
            "to unit), each claim is paired per unit under the same rule: the mean "
            "difference method − reference [nmi] with its 95 % Student-t interval over "
            "units. Every figure, the paired differences and the distributions are in "
            "study/report.html beside this page; its claims in study/claims.csv."
        )
        s.table(
            "study_claims",
            claims_view(study.claim_rows, "units"),
            "The claims over the units (method − reference [nmi])",
        )
        s.raw('<p><a href="study/report.html">The study\'s report</a></p>')

    s = rep.section("Calibration data (Table 3, Figure 3)", "calibration-data")
    s.text(
        f"Seven soak cold starts at 0, 7, 14, 21, 28, 35, 42 °C, {cfg.soak_hours:g} h each at "
        f"{cfg.cal_rate_hz:g} Hz, no rotation; the unit had soaked before each power-on. "
        "Held out: a repetition-priming cold start at 25 °C and the −2 → 50 °C chamber ramp."
    )
    soak = cal.logs["soak"]
    tcols = [c for c in soak.columns if c.startswith("temp_") and c != "temp_out"]
    t_lo, t_hi = float(soak[tcols].min().min()), float(soak[tcols].max().max())
    s.text(
        "The figure below shows every output and temperature of the seven soak runs, the "
        "only data any model is fitted to: each output drifts as the unit warms after its "
        f"power-on, and the inner temperatures span {t_lo:.1f} to {t_hi:.1f} °C. What a "
        "model never sees here (other rates of warming, other gradients) is what the "
        "held-out runs below test."
    )
    s.figure(
        "soak", figures["soak"], "Figure 3: outputs and temperatures of the soak runs", fold=True
    )

    add_calibration_sections(rep, cal, tables, figures, words[:-1])

    ramp = [r for r in nav if r.job.experiment == "ramp"]
    s = rep.section("Navigation in the chamber ramp (Figure 9)", "ramp")
    if ramp:
        r = ramp[0]
        ch = r.temperatures["chamber"]
        s.text(
            f"The figure below shows the horizontal position error against time of the "
            f"quasi-static RINS while the chamber goes from {ch.min():.0f} to "
            f"{ch.max():.0f} °C ({r.job.hours:g} h). It tests extrapolation more than the "
            f"models: {_ramp_domain_words(tables)} On this run: {_max_words(r)}."
        )
    s.figure("nav_ramp", figures["nav_ramp"], "Figure 9: quasi-static RINS, chamber −2 → 50 °C")
    s.table(
        "ramp_max",
        run_table_view(tables["ramp_max"], LABELS, "nmi"),
        "Chamber ramp: maximum position error [nmi]",
    )

    s = rep.section("Lab cold starts: quasi-static and swing (Figures 11-13)", "lab")
    start = f" starting {cfg.align_start_s:g} s after power-on" if cfg.align_start_s else ""
    s.text(
        "Each run: cold start, self-alignment (coarse, then a Kalman filter on zero "
        f"velocity, {cfg.align_s:g} s{start}), then free navigation with four-position "
        "modulation. All methods navigate on the same raw IMU output of a run, so the gaps "
        "between the curves of a run are the compensation alone."
    )
    for key, exp, scen, what in (
        ("nav_qs", "lab", "quasi-static", "the first quasi-static cold start"),
        ("nav_swing", "lab", "swing", "the first swing cold start"),
    ):
        r = next((x for x in nav if x.job.experiment == exp and x.job.scenario == scen), None)
        if r is not None:
            s.text(
                f"The figure below shows the position error against time of {what} "
                f"(experiment {r.job.index}, {r.job.ambient_c:g} °C), one curve per variant, "
                f"to show how each compensation's error grows over the run: {_max_words(r)}."
            )
        fig_no = 11 if scen == "quasi-static" else 12
        number = f", experiment {r.job.index}" if r is not None else ""
        s.figure(key, figures[key], f"Figure {fig_no}: {scen}{number}", fold=True)
    s.text(_lab_bars_words(tables["lab_max"]))
    s.figure("lab_bars", figures["lab_bars"], "Figure 13: maximum errors of experiments 1-10")
    s.table(
        "lab_max",
        run_table_view(tables["lab_max"], LABELS, "nmi"),
        "Maximum horizontal position error [nmi]",
        fold=True,
    )

    s = rep.section("Vehicle experiments (Figures 15, 16, Table 10)", "vehicle")
    veh = [r for r in nav if r.job.experiment == "vehicle"]
    if veh:
        r = veh[0]
        s.text(
            f"The figure below draws the route of vehicle run {r.job.index} and the track "
            "each compensation's INS computed on it, to show where the tracks part from the "
            f"truth; {_max_words(r, ('none', 'sectional', 'regression', 'neural'))}."
        )
    s.figure("vehicle_track", figures["vehicle_track"], "Figure 15: trajectories, run 1", fold=True)
    if veh:
        r = veh[0]
        t_max = {
            k: v["time_of_max_s"] / units.HOUR_TO_S
            for k, v in r.summary["variants"].items()
            if k in VARIANTS
        }
        if len({round(x, 2) for x in t_max.values()}) == 1:
            when = f"every variant reaches its maximum at {next(iter(t_max.values())):.2f} h"
        else:
            when = "each reaches its maximum at: " + ", ".join(
                f"{LABELS[k]} {x:.2f} h" for k, x in t_max.items()
            )
        s.text(
            "The figure below is the position error of the same run against time (Figure "
            "16), with the baseline and the oracle added, to show when during the drive each "
            f"variant's error grows; {when} (the run lasts "
            f"{r.summary['duration_s'] / units.HOUR_TO_S:.2f} h)."
        )
    s.figure("nav_vehicle", figures["nav_vehicle"], "Figure 16: position errors, run 1")
    s.table(
        "table10",
        run_table_view(tables["table10"], LABELS, "nmi"),
        "Table 10: maximum position error [nmi] and decrease from method 1 to 3",
    )
    s.text(_temperature_words(nav, t_lo, t_hi))
    s.figure(
        "temperatures",
        figures["temperatures"],
        "Thermal scenarios of the navigation runs",
        fold=True,
    )

    nav_sections(rep, tables, figures, _mechanism_summary(tables), _nav_labels())

    if cal.imu_cal is not None:
        imu_section(rep, cal, tables)

    s = rep.section("How this was made", "method")
    rows = "".join(f"<li>{_esc(k)}: {v:.1f} s</li>" for k, v in timings.items())
    s.text(f"Command: {command_line(cfg, out, _study_units(study))}")
    s.raw(
        f"<p>{_plant_html(plant)} Settings:</p><ul>"
        + "".join(f"<li><code>{_esc(f'{k} = {v}')}</code></li>" for k, v in vars(cfg).items())
        + "</ul><p>Stage times (wall clock of each stage, as the progress bar counted "
        f"them; the report's own stage and the total are in metrics.json, timings_s):</p>"
        f"<ul>{rows}</ul>"
    )
    _ = PAPER
    return rep


def _nav_labels() -> dict[str, str]:
    return {**LABELS, ORACLE_NO_OFFSETS: ORACLE_NO_OFFSETS_LABEL}


def _mechanism_summary(tables: Mapping[str, pd.DataFrame]) -> dict[str, Any] | None:
    """:func:`mechanism_summary` of the report's tables (None without them; NaN, e.g. no
    run with a prediction, written as null)."""
    if not all(t in tables for t in MECHANISM_TABLES):
        return None
    m = mechanism_summary(tables["mechanism"], tables["oracle_decomposition"], tables["modulation"])
    return {k: None if isinstance(v, float) and not np.isfinite(v) else v for k, v in m.items()}


def command_line(cfg: ReproConfig, out: Path | None = None, units: int = 0) -> str:
    """The ``rinscal reproduce`` command that re-runs ``cfg``: with ``--units`` where a
    study of ``units`` units ran and ``--out`` where the output folder ``out`` is given
    (the report's "How this was made" gives both: the exact command)."""
    parts = ["rinscal reproduce"]
    if cfg.quick:
        parts.append("--quick")
    parts += [f"--seed {cfg.seed}", f"--imu {cfg.imu}", f"--align-s {cfg.align_s:g}"]
    if cfg.align_start_s:
        parts.append(f"--align-start-s {cfg.align_start_s:g}")
    if units:
        parts.append(f"--units {units}")
    if out is not None:
        parts.append(f"--out {shlex.quote(str(out))}")
    return " ".join(parts)


def _esc(text: str) -> str:
    return html.escape(text)


def _study_units(study: Any) -> int:
    """How many units the ``--units`` study of a reproduction ran (0: none)."""
    if study is None or study.results.empty:
        return 0
    return int(study.results["unit"].nunique())


def _maxerr_from(tables: Mapping[str, pd.DataFrame]) -> pd.DataFrame:
    """The lab and vehicle rows of the max-error table, rebuilt from the report's tables."""
    parts = []
    for key, exp in (("lab_max", "lab"), ("table10", "vehicle")):
        if key in tables:
            parts.append(tables[key].assign(experiment=exp))
    return pd.concat(parts, ignore_index=True)


def _lab_bars_words(lab: pd.DataFrame) -> str:
    parts = []
    for scen in ("quasi-static", "swing"):
        sc = lab[lab["scenario"] == scen]
        if sc.empty:
            continue
        n = len(sc)
        k12 = int((sc["regression"] < sc["sectional"]).sum())
        k13 = int((sc["neural"] < sc["sectional"]).sum())
        kn = int((sc[list(METHODS)].min(axis=1) < sc["none"]).sum())
        parts.append(
            f"in the {scen} runs method 2 beats method 1 in {k12} of {n}, method 3 beats "
            f"method 1 in {k13} of {n}, and the best model beats no compensation in {kn} "
            f"of {n}"
        )
    return (
        "The figure below shows the maximum position error of each lab experiment and "
        "method side by side (Figure 13), to show how the ranking of the methods changes "
        f"from run to run: {'; '.join(parts)}."
    )


def _temperature_words(nav: Sequence[NavRunResult], t_lo: float, t_hi: float) -> str:
    lo = min(float(r.temperatures["sensor_gyro_z"].min()) for r in nav)
    hi = max(float(r.temperatures["sensor_gyro_z"].max()) for r in nav)
    return (
        "The figure below shows the thermal scenario of every navigation run (gyro z inner "
        "temperature solid, ambient dotted), to show what the models face in navigation: "
        f"inner temperatures from {lo:.1f} to {hi:.1f} °C, against {t_lo:.1f} to {t_hi:.1f} "
        "°C in the soak runs they were trained on."
    )


def _fmt_values(c: Mapping[str, Any]) -> str:
    for key in ("values_ug", "values_nmi"):
        if key in c:
            v = c[key]
            if isinstance(v, dict):
                return "; ".join(f"{k} {_num(x)}" for k, x in v.items())
            return _num(list(v)) if len(v) == 2 else ", ".join(_num(x) for x in v)
    return ""


def _num(x: Any) -> str:
    """A claim's value: a pair (ours, the other) as "9.91 vs 17.6", a number to 3 digits."""
    if isinstance(x, list | tuple):
        return " vs ".join(_num(y) for y in x)
    return f"{x:.3g}" if isinstance(x, float) else str(x)


def render_figures(
    cal: CalibrationResult, nav: Sequence[NavRunResult], maxerr: pd.DataFrame
) -> dict[str, bytes]:
    """Every figure of the report as PNG bytes."""

    def first(exp: str, scen: str) -> NavRunResult:
        return next(r for r in nav if r.job.experiment == exp and r.job.scenario == scen)

    figs = {
        "soak": plot_log(
            cal.logs["soak"],
            units={c: cal.metas["soak"]["units"][c] for c in cal.metas["soak"]["units"]},
            title="Soak calibration runs (Table 3)",
            max_bins=400,
        ),
        "selection": fig_selection(cal),
        "repeat": fig_repeat(cal),
        "nav_ramp": fig_nav_errors(
            first("ramp", "ramp"), "Figure 9: chamber ramp −2 → 50 °C at 0.2 °C/min"
        ),
        "nav_qs": fig_nav_errors(
            first("lab", "quasi-static"), "Figure 11: quasi-static cold start (experiment 1)"
        ),
        "nav_swing": fig_nav_errors(
            first("lab", "swing"), "Figure 12: swing cold start (first swing experiment)"
        ),
        "lab_bars": fig_lab_bars(maxerr),
        "vehicle_track": fig_vehicle_track(first("vehicle", "vehicle")),
        "nav_vehicle": fig_nav_errors(
            first("vehicle", "vehicle"), "Figure 16: vehicle experiment 1"
        ),
        "temperatures": fig_temperatures(nav),
    }
    if nav and all(f"{v}_heading" in r.errors for r in nav for v in ("none",)):
        figs["heading_velocity"] = fig_heading_velocity(
            [first("lab", "quasi-static"), first("vehicle", "vehicle")], _nav_labels()
        )
    if cal.allan_curves:
        units = {c: cal.metas["repeat"]["units"].get(c, "?") for c in cal.allan_curves}
        figs["allan"] = allan_figure(cal.allan_curves, units, title="Repeat run at 25 °C")
        order = list(figs)  # in the report's order: right after the repeat figure
        order.insert(order.index("repeat") + 1, order.pop(order.index("allan")))
        figs = {k: figs[k] for k in order}
    return {k: figure_to_png(f) for k, f in figs.items()}


__all__ = [
    "build_report",
    "command_line",
    "render_figures",
    "reproduction_tables",
    "words_uncompensated_heldout",
    "words_uncompensated_nav",
    "write_reproduction",
]


# --------------------------------------------------------------------------- files
class Written:
    """What :func:`write_reproduction` wrote."""

    def __init__(self, out: Path, maxerr: pd.DataFrame, tables: dict[str, pd.DataFrame]) -> None:
        self.out = out
        self.maxerr = maxerr
        self.tables = tables
        self.report_path = out / "report.html"
        self.metrics_path = out / "metrics.json"


def reproduction_tables(
    cal: CalibrationResult, nav: Sequence[NavRunResult], plant: str = ""
) -> tuple[pd.DataFrame, dict[str, pd.DataFrame]]:
    """Every table of the reproduction (name -> DataFrame) and the max-error table;
    ``plant`` names the plant in the claims (``claims``, ``verdict_means``)."""
    maxerr = max_error_table(nav)
    tables = dict(cal.tables)
    tables["claims"] = paired_claims(maxerr, plant)
    tables["verdict_means"] = group_means(maxerr, plant)
    tables["verdict"] = verdict_table(tables["verdict_means"], tables["claims"])
    tables["paired_paper"] = claims_view(
        tables["claims"][
            [
                (m, r) in PAPER_PAIRS
                for m, r in zip(
                    tables["claims"]["method"], tables["claims"]["reference"], strict=True
                )
            ]
        ]
    )
    tables["lab_max"] = maxerr[maxerr["experiment"] == "lab"].drop(columns="experiment")
    veh = maxerr[maxerr["experiment"] == "vehicle"].drop(columns="experiment").copy()
    veh["decrease m1→m3 [%]"] = decrease_pct(veh["sectional"], veh["neural"])
    veh["decrease m1→m2 [%]"] = decrease_pct(veh["sectional"], veh["regression"])
    tables["table10"] = veh
    tables["ramp_max"] = maxerr[maxerr["experiment"] == "ramp"].drop(columns="experiment")
    tables["summary"] = summary_table(maxerr)
    tables["selection_vs_paper"] = selection_summary_table(cal)
    heading = heading_error_table(nav)
    tables["heading_at_nav_start"] = heading
    tables["nav_by_method"] = nav_method_table(maxerr, heading)
    # the heading half of it, shown as its own table on the page
    nbm = tables["nav_by_method"]
    tables["nav_heading_by_method"] = nbm[
        ["runs", "variant", "method", *[c for c in nbm.columns if "heading" in c]]
    ]
    tables["thermal_part"] = thermal_part_table(nav)
    compared = [v for v in (*VARIANTS, IMU_VARIANT) if v in maxerr]
    tables["paired_vs_none"] = paired_table(maxerr, "none", compared)
    tables["paired_vs_poly_t"] = paired_table(maxerr, "poly-t", compared)
    if nav and all(r.mechanism for r in nav):
        tables.update(mechanism_tables(nav))
    if cal.imu_cal is not None and nav and IMU_VARIANT in nav[0].summary.get("variants", {}):
        both = variant_table(nav, ["regression", IMU_VARIANT])
        tables["imu_nav"] = both
        tables["imu_saving"] = paired_saving_table(both)
    return maxerr, tables


def _records(df: pd.DataFrame) -> list[dict[str, Any]]:
    """Rows of a table for JSON, NaN written as null."""

    def clean(v: Any) -> Any:
        return None if isinstance(v, float) and not np.isfinite(v) else v

    return [{k: clean(v) for k, v in rec.items()} for rec in df.to_dict(orient="records")]


def findings(tables: Mapping[str, pd.DataFrame]) -> dict[str, Any]:
    """Where no compensation beats a model, as data and as the report's sentences."""
    h = tables["heldout_residual"]
    logs = list(dict.fromkeys(h["log"]))
    maxerr = _maxerr_from(tables)
    return {
        "uncompensated_beats_heldout": {log: uncompensated_wins_heldout(h, log) for log in logs},
        "uncompensated_beats_nav_nmi": {
            g: {m: list(v) for m, v in d.items()} for g, d in uncompensated_wins_nav(maxerr).items()
        },
        "sentences": [words_uncompensated_heldout(h, log) for log in logs]
        + [words_uncompensated_nav(maxerr)],
    }


def write_reproduction(
    out: Path,
    cfg: ReproConfig,
    cal: CalibrationResult,
    nav: Sequence[NavRunResult],
    timings: Mapping[str, float],
    plant: Mapping[str, Any] | None = None,
    study: Any = None,
) -> Written:
    """Write report.html, figures/*.png, tables/*.csv, models/*.json and metrics.json.

    ``plant`` is :func:`rinscal.experiments.paper.config.plant_info` of the IMU that ran (default:
    from ``cfg.imu`` and ``cal.imu``).
    """
    if plant is None:
        plant = plant_info(cfg.imu, cal.imu or load_plant(cfg.imu))
    maxerr, tables = reproduction_tables(cal, nav, str(plant["spec"]))
    checked = claims(cal)
    figures = render_figures(cal, nav, maxerr)
    for sub in ("figures", "tables", "models"):
        (out / sub).mkdir(parents=True, exist_ok=True)
    for name, png in figures.items():
        write_atomic(out / "figures" / f"{name}.png", lambda tmp, png=png: tmp.write_bytes(png))
    for name, df in tables.items():
        write_atomic(out / "tables" / f"{name}.csv", lambda tmp, df=df: df.to_csv(tmp, index=False))
    for m, model in {**cal.models, **cal.extra_models}.items():
        model.save(out / "models" / f"{m}.json")
    rep = build_report(
        cfg, cal, nav, tables, checked, figures, timings, plant=plant, study=study, out=out
    )
    page = rep.to_html()
    write_claims_csv(out / "claims.csv", tables["claims"])
    write_atomic(out / "report.html", lambda tmp: tmp.write_text(page, encoding="utf-8"))
    metrics = {
        "mode": "quick" if cfg.quick else "full",
        "imu": dict(plant),
        "command": command_line(cfg, out, _study_units(study)),
        "config": {k: (list(v) if isinstance(v, tuple) else v) for k, v in vars(cfg).items()},
        "claims": checked,
        "verdicts": _records(tables["claims"]),
        "figures": rep.figure_ids(),
        "tables": rep.table_ids(),
        "navigation": [
            {
                "experiment": r.job.experiment,
                "scenario": r.job.scenario,
                "number": r.job.index,
                "ambient_c": r.job.ambient_c,
                "summary": r.summary,
            }
            for r in nav
        ],
        "heldout_residual": _records(tables["heldout_residual"]),
        "repeat_steps": _records(tables["repeat_steps"]),
        "summary": _records(tables["summary"]),
        "nav_by_method": _records(tables["nav_by_method"]),
        "heading_at_nav_start_arcsec": _records(tables["heading_at_nav_start"]),
        "findings": findings(tables),
        "mechanism": _mechanism_summary(tables),
        "selection": {m: s.to_dict() for m, s in cal.selection.items()},
    }
    if "imu_recovery" in tables:
        metrics["imu_calibration"] = {
            "recovery": _records(tables["imu_recovery"]),
            "saving_nmi": _records(tables.get("imu_saving", pd.DataFrame())),
            "warnings": list(cal.imu_cal.result.warnings),
        }
    text = json.dumps(metrics, indent=2, default=_json_default, allow_nan=False) + "\n"
    write_atomic(out / "metrics.json", lambda tmp: tmp.write_text(text))
    return Written(out, maxerr, tables)


def _json_default(obj: object) -> object:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")
