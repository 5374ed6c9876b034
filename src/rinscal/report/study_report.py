"""The report of a study: ``report.html`` (self-contained), ``tables/*.csv``,
``summary.json``.

Everything is computed from the results folder (:class:`rinscal.experiments.study.runner.
StudyStore`) by :mod:`rinscal.experiments.study.stats`; the report can be rebuilt from the
folder at any time, and a resumed study's report covers every task that ever finished.
"""

from __future__ import annotations

import html
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rinscal._version import __version__
from rinscal.experiments.paper.config import LABELS
from rinscal.experiments.study.runner import RunSummary, StudyStore
from rinscal.experiments.study.spec import StudySpec, plant_table, sweep_columns
from rinscal.experiments.study.stats import (
    CONFIDENCE,
    claims_table,
    method_summary,
    paired_differences,
    sensitivity_map,
    structure_findings,
    structure_pairs,
    uncompensated_wins,
)
from rinscal.io.atomic import write_atomic
from rinscal.report.html import Report, figure_to_png

#: Colours of the variants in every figure.
COLORS = {
    "none": "#6e7781",
    "poly-t": "#8250df",
    "sectional": "#cf222e",
    "regression": "#0969da",
    "neural": "#1a7f37",
    "true": "#000000",
}


@dataclass
class StudyTables:
    """Every table of a study's report."""

    results: pd.DataFrame
    plants: pd.DataFrame
    summary: pd.DataFrame
    pairs: pd.DataFrame
    claims: pd.DataFrame
    sensitivity: pd.DataFrame
    failures: pd.DataFrame
    uncompensated: list[str] = field(default_factory=list)
    structure: list[str] = field(default_factory=list)


@dataclass
class WrittenStudy:
    """What :func:`write_study_report` wrote, and the verdicts in words."""

    report: Path
    tables: StudyTables
    verdicts: list[str]


def study_tables(store: StudyStore, spec: StudySpec) -> StudyTables:
    """The statistics of every finished task of ``spec`` in ``store``."""
    results = store.read_results(spec)
    plants = plant_table(spec)
    if results.empty:
        empty = pd.DataFrame()
        return StudyTables(results, plants, empty, empty, empty, empty, store.failures())
    summary = method_summary(results)
    pairs = paired_differences(results)
    claims = claims_table(results, pairs)
    return StudyTables(
        results=results,
        plants=plants,
        summary=summary,
        pairs=pairs,
        claims=claims,
        sensitivity=sensitivity_map(pairs, plants) if sweep_columns(spec) else pd.DataFrame(),
        failures=store.failures(),
        uncompensated=uncompensated_wins(pairs),
        structure=structure_findings(claims, summary, plants, pairs),
    )


def verdict_lines(t: StudyTables) -> list[str]:
    """The findings in words: each claim's verdict, where no compensation wins, and the
    sensitivity map's reading."""
    out = []
    for _, r in t.claims.iterrows():
        out.append(f"{r['plant']}, {r['scenario']}: {r['claim']} — {r['verdict']}")
    out.extend(t.uncompensated)
    out.extend(t.structure)
    s = t.sensitivity
    if not s.empty:
        for tag, name in (("m2", "method 2"), ("m3", "method 3")):
            col = f"{tag} verdict"
            if col not in s:
                continue
            pays = s[s[col] == "pays"]
            loses = s[s[col] == "loses"]
            out.append(
                f"sensitivity map: {name} beats method 1 by a margin whose 95 % interval "
                f"excludes zero in {len(pays)} of {len(s)} cells"
                + (f", loses in {len(loses)}" if len(loses) else "")
                + (
                    "; it pays at: "
                    + "; ".join(
                        f"{p} ({sc})"
                        for p, sc in zip(pays["plant_label"], pays["scenario"], strict=True)
                    )
                    if 0 < len(pays) <= 8
                    else ""
                )
            )
    return out


# --------------------------------------------------------------------------- figures
def _distribution_figure(results: pd.DataFrame, plant: int) -> bytes:
    # deferred: matplotlib loads in ~0.3 s, for figures only; Agg is chosen before pyplot
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    df = results[results["plant"] == plant]
    scens = list(dict.fromkeys(df["scenario"]))
    variants = [v for v in COLORS if v in set(df["variant"])]
    fig, axes = plt.subplots(1, len(scens), figsize=(4.2 * len(scens), 3.8), squeeze=False)
    rng = np.random.default_rng(0)
    for ax, scen in zip(axes[0], scens, strict=True):
        g = df[df["scenario"] == scen]
        data = [g.loc[g["variant"] == v, "max_error_nmi"].to_numpy(float) for v in variants]
        ax.boxplot(data, showfliers=False, widths=0.6)
        for i, (v, y) in enumerate(zip(variants, data, strict=True)):
            x = i + 1 + rng.uniform(-0.18, 0.18, y.size)
            ax.plot(x, y, ".", color=COLORS[v], alpha=0.5, ms=4)
            ax.plot(i + 1, np.mean(y), "D", color="k", ms=4)
        ax.set_xticks(
            range(1, len(variants) + 1),
            [LABELS[v].split(" (")[0] for v in variants],
            rotation=35,
            ha="right",
            fontsize=8,
        )
        ax.set_title(scen, fontsize=10)
        ax.set_ylabel("max horizontal position error [nmi]")
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle(
        f"{df['plant_label'].iloc[0]}: every run (dots), mean (◆), box = quartiles", fontsize=10
    )
    fig.tight_layout()
    return figure_to_png(fig)


_FOREST = (
    ("sectional", "regression"),
    ("sectional", "neural"),
    ("regression", "neural"),
    ("poly-t", "regression"),
    ("none", "regression"),
)


def _forest_figure(pairs: pd.DataFrame, plant: int) -> bytes:
    # deferred: matplotlib loads in ~0.3 s, for figures only; Agg is chosen before pyplot
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    p = pairs[(pairs["plant"] == plant) & (pairs["metric"] == "max_error_nmi")]
    scens = list(dict.fromkeys(p["scenario"]))
    fig, axes = plt.subplots(
        1, len(scens), figsize=(4.2 * len(scens), 3.2), squeeze=False, sharey=True
    )
    for ax, scen in zip(axes[0], scens, strict=True):
        g = p[p["scenario"] == scen]
        labels = []
        for i, (a, b) in enumerate(_FOREST):
            r = g[(g["a"] == a) & (g["b"] == b)]
            labels.append(f"{a} → {b}")
            if r.empty:
                continue
            r = r.iloc[0]
            lo, hi, m = r["decrease ci low"], r["decrease ci high"], r["decrease %"]
            color = "#1a7f37" if lo > 0 else "#cf222e" if hi < 0 else "#6e7781"
            err = [[max(0.0, m - lo)], [max(0.0, hi - m)]] if np.isfinite([lo, hi]).all() else None
            ax.errorbar(m, i, xerr=err, fmt="o", color=color, capsize=3)
        ax.axvline(0, color="k", lw=0.8)
        ax.set_yticks(range(len(_FOREST)), labels, fontsize=8)
        ax.invert_yaxis()
        ax.set_title(scen, fontsize=10)
        ax.set_xlabel("decrease of mean max error [%]")
        ax.grid(axis="x", alpha=0.3)
    fig.suptitle(
        f"paired decrease a → b with its {CONFIDENCE:.0%} interval (green: b better, "
        "red: b worse, grey: not resolved)",
        fontsize=9,
    )
    fig.tight_layout()
    return figure_to_png(fig)


def _map_figure(sens: pd.DataFrame) -> bytes:
    # deferred: matplotlib loads in ~0.3 s, for figures only; Agg is chosen before pyplot
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scens = list(dict.fromkeys(sens["scenario"]))
    tags = [t for t in ("m2", "m3") if f"{t} decrease %" in sens]
    cols = [(s, t) for s in scens for t in tags]
    labels = list(dict.fromkeys(sens["plant_label"]))
    z = np.full((len(labels), len(cols)), np.nan)
    txt = [["" for _ in cols] for _ in labels]
    for j, (s, t) in enumerate(cols):
        for i, lab in enumerate(labels):
            r = sens[(sens["scenario"] == s) & (sens["plant_label"] == lab)]
            if r.empty:
                continue
            r = r.iloc[0]
            z[i, j] = r[f"{t} decrease %"]
            mark = {"pays": "✓", "loses": "✗"}.get(r[f"{t} verdict"], "~")
            txt[i][j] = f"{mark} {z[i, j]:.0f}%\n[{r[f'{t} ci low']:.0f}, {r[f'{t} ci high']:.0f}]"
    lim = float(np.nanmax(np.abs(z))) if np.isfinite(z).any() else 1.0
    fig, ax = plt.subplots(figsize=(2.0 + 1.9 * len(cols), 0.9 + 0.55 * len(labels)))
    im = ax.imshow(z, cmap="RdYlGn", vmin=-lim, vmax=lim, aspect="auto")
    for i in range(len(labels)):
        for j in range(len(cols)):
            ax.text(j, i, txt[i][j], ha="center", va="center", fontsize=7)
    names = {"m2": "method 1 → 2", "m3": "method 1 → 3"}
    ax.set_xticks(range(len(cols)), [f"{s}\n{names[t]}" for s, t in cols], fontsize=8)
    ax.set_yticks(range(len(labels)), labels, fontsize=8)
    fig.colorbar(im, ax=ax, label="decrease of mean max error [%]")
    ax.set_title("✓ pays (interval above 0) · ✗ loses (below 0) · ~ not resolved", fontsize=9)
    fig.tight_layout()
    return figure_to_png(fig)


# --------------------------------------------------------------------------- the report
def _fmt_ci(m: float, lo: float, hi: float, nd: int = 3) -> str:
    if not math.isfinite(m):
        return ""
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return f"{m:.{nd}f}"
    return f"{m:.{nd}f} [{lo:.{nd}f}, {hi:.{nd}f}]"


def _summary_view(summary: pd.DataFrame, metric: str) -> pd.DataFrame:
    s = summary[summary["metric"] == metric]
    nd = {"nmi": 3, "ug": 2, "dph": 5, "pct": 1}.get(metric.rsplit("_", 1)[-1], 0)
    return pd.DataFrame(
        {
            "plant": s["plant_label"],
            "scenario": s["scenario"],
            "method": s["method"],
            "units": s["n units"],
            "runs": s["n runs"],
            f"mean [{CONFIDENCE:.0%} CI]": [
                _fmt_ci(m, lo, hi, nd)
                for m, lo, hi in zip(s["mean"], s["ci low"], s["ci high"], strict=True)
            ],
            "median": s["median"],
            "sd": s["sd"],
            "min": s["min"],
            "max": s["max"],
        }
    )


def _pairs_view(pairs: pd.DataFrame) -> pd.DataFrame:
    p = pairs[pairs["metric"] == "max_error_nmi"]
    return pd.DataFrame(
        {
            "plant": p["plant_label"],
            "scenario": p["scenario"],
            "a → b": p["comparison"],
            "mean a − b [nmi]": [
                _fmt_ci(m, lo, hi)
                for m, lo, hi in zip(
                    p["difference"], p["diff ci low"], p["diff ci high"], strict=True
                )
            ],
            "decrease [%]": [
                _fmt_ci(m, lo, hi, 1)
                for m, lo, hi in zip(
                    p["decrease %"], p["decrease ci low"], p["decrease ci high"], strict=True
                )
            ],
            "b better: units": p["b better: units"],
            "b better: runs": p["b better: runs"],
            "best run (a maximum) [%]": p["best decrease over the runs %"],
        }
    )


def claims_view(claims: pd.DataFrame) -> pd.DataFrame:
    """The claims table as shown: our mean decrease with its interval in one column."""
    view = claims.copy()
    view["ours: mean [CI] %"] = [
        _fmt_ci(m, lo, hi, 1)
        for m, lo, hi in zip(
            view["ours: mean decrease %"], view["ci low"], view["ci high"], strict=True
        )
    ]
    cols = [
        "plant",
        "scenario",
        "claim",
        "paper %",
        "paper's figure is",
        "ours: mean [CI] %",
        "ours: best run %",
        "b better: units",
        "verdict",
    ]
    return view[cols]


def build_report(spec: StudySpec, t: StudyTables, run: RunSummary | None) -> Report:
    """The HTML report of a study from its tables."""
    rep = Report(
        f"rinscal study: {spec.name}",
        f"rinscal {__version__} · {spec.units} unit(s) · seed {spec.seed}"
        + (" · quick sizes" if spec.quick else "")
        + " · every figure a simulation",
    )
    s = rep.section("What ran", "what")
    s.text(spec.description or spec.name)
    n_runs = t.results.drop_duplicates(["plant", "unit", "scenario", "start"]).shape[0]
    s.text(
        f"{len(spec.plants)} plant variant(s), {spec.units} unit(s) each (unit-to-unit spread "
        f"of the thermal coefficients {spec.coefficient_spread:.0%}, 1σ), each unit calibrated "
        f"on its own soak runs ({spec.calibration.hours:g} h per run at "
        f"{spec.calibration.rate_hz:g} Hz) and navigated in "
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
        f"Intervals are {CONFIDENCE:.0%} BCa bootstrap intervals over units (a unit's starts "
        "are averaged first; they share its calibration). Comparisons are paired: both methods "
        "on the same unit and cold start. 'Best run' columns are maxima over single runs, the "
        "paper's 'up to' figures; they are not estimates.",
        "note",
    )
    if t.results.empty:
        s.text("No navigation task has finished yet.", "banner")
        return rep
    if not t.claims.empty:
        c = rep.section("The paper's claims", "claims")
        c.text(
            "Each claim of the paper's Section 5 with our mean decrease of the maximum position "
            "error, its interval and a verdict. The paper's lab figures are its best run "
            "('up to'); our mean is the figure to adopt a method on."
        )
        c.table(
            "claims",
            claims_view(t.claims),
            "The paper's claims with our interval and verdict",
            "{:.3g}",
        )
    if t.structure:
        st = rep.section("Does the verdict survive a change of thermal law?", "structure")
        pairs_ = structure_pairs(t.plants)
        st.text(
            "The study ran plants that differ only in their thermal law: "
            + "; ".join(
                f"{a['plant_label']} (polynomial) and {b['plant_label']} (mechanistic)"
                for a, b in pairs_
            )
            + ". The polynomial law is, term for term, the paper's method-2 regression, so a "
            "verdict for method 2 on it partly measures the plant's own shape; the mechanistic "
            "law drives each bias by nodes of the thermal network that no thermometer sees "
            "(the electronics box through a lag, the box-to-mount gradient, the package "
            "stress, a saturating own temperature), which no model class here represents. "
            "A finding that holds on both is one the plant's shape did not decide."
        )
        st.raw("<ul>" + "".join(f"<li>{html.escape(x)}</li>" for x in t.structure) + "</ul>")
    if "accel_residual_pct" in set(t.summary.get("metric", [])):
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
        for metric, caption, fmt in (
            (
                "accel_residual_pct",
                "Horizontal accelerometers: share of the thermal swing left [%]",
                "{:.1f}",
            ),
            ("accel_residual_ug", "Horizontal accelerometers: residual RMS [µg]", "{:.2f}"),
            ("gyro_residual_dph", "Gyros: residual RMS, worst axis [°/h]", "{:.2g}"),
        ):
            h.table(f"summary_{metric}", _summary_view(t.summary, metric), caption, fmt)
    if t.uncompensated:
        u = rep.section("Where no compensation wins", "uncompensated")
        u.raw("<ul>" + "".join(f"<li>{html.escape(x)}</li>" for x in t.uncompensated) + "</ul>")
    d = rep.section("Distributions per method", "distributions")
    plants = list(dict.fromkeys(t.results["plant"]))
    shown = plants if len(plants) <= 2 else plants[:1]
    for p in shown:
        d.figure(
            f"distribution-p{p}",
            _distribution_figure(t.results, p),
            "Maximum horizontal position error of every run, per method and scenario",
        )
    if len(shown) < len(plants):
        d.text(
            f"Figures for the first plant variant only; {len(plants)} variants are in the "
            "tables and the sensitivity map.",
            "note",
        )
    d.table(
        "summary_max_error",
        _summary_view(t.summary, "max_error_nmi"),
        "Maximum horizontal position error per run [nmi]",
        "{:.3f}",
    )
    d.table(
        "summary_thermal_part",
        _summary_view(t.summary, "thermal_part_nmi"),
        "Its thermal part: the variant's position error minus the oracle's [nmi]",
        "{:.3f}",
    )
    d.table(
        "summary_heading",
        _summary_view(t.summary, "abs_heading_error_arcsec"),
        "|heading error| at the start of free navigation [arcsec]",
        "{:.0f}",
    )
    pr = rep.section("Paired differences", "paired")
    for p in shown:
        pr.figure(
            f"paired-p{p}",
            _forest_figure(t.pairs, p),
            "Decrease of the mean maximum position error from method a to method b",
        )
    pr.table(
        "pairs",
        _pairs_view(t.pairs),
        "Paired differences of the maximum position error (a − b > 0: b is better)",
        "{:.2f}",
    )
    if not t.sensitivity.empty:
        m = rep.section("Sensitivity map", "sensitivity")
        m.text(
            "Where do methods 2 and 3 beat method 1? Each cell is the decrease of the mean "
            "maximum position error from method 1 (sectional) to method 2 (regression) or "
            "method 3 (BP network) with its interval; a method pays where the interval lies "
            "above zero."
        )
        m.figure("sensitivity-map", _map_figure(t.sensitivity), "The sensitivity map")
        m.table("sensitivity", t.sensitivity, "The sensitivity map as a table", "{:.3g}")
    if not t.failures.empty:
        f = rep.section("Failed tasks", "failures")
        f.text(
            f"{len(t.failures)} task(s) raised; the statistics leave them out. Run the "
            "study again with --retry-failed to retry them.",
            "banner",
        )
        f.table("failures", t.failures, "Tasks that raised and their errors")
    return rep


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
        "claims": t.claims,
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
    write_atomic(root / "report.html", lambda tmp: tmp.write_text(page, encoding="utf-8"))
    return WrittenStudy(root / "report.html", t, verdicts)


__all__ = [
    "StudyTables",
    "WrittenStudy",
    "build_report",
    "study_tables",
    "verdict_lines",
    "write_study_report",
]
