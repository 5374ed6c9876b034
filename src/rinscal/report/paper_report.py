"""Figures and the HTML report of ``rinscal reproduce`` (the paper's Section 5 side by side).

Every function takes the data the experiments returned and gives back a matplotlib figure
or fills a report section; nothing here computes a result.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from rinscal import units
from rinscal.experiments.paper import (
    LABELS,
    METHODS,
    PAPER,
    VARIANTS,
    CalibrationResult,
    NavRunResult,
    ReproConfig,
)
from rinscal.report.html import Report, figure_to_png

COLORS = {
    "none": "#7f7f7f",
    "poly-t": "#9467bd",
    "sectional": "#d62728",
    "regression": "#1f77b4",
    "neural": "#2ca02c",
    "true": "#000000",
}
STYLES = {"true": ":", "none": "--"}


def fig_repeat(cal: CalibrationResult) -> Figure:
    """Figures 7 and 8: x-axis outputs of the repeat run before and after compensation."""
    df = cal.repeat_curves
    assert df is not None
    edges = np.asarray(cal.models["sectional"].models["accel_x"].segment_edges, dtype=float)
    fig = Figure(figsize=(11, 6.5), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True)
    t = df["time_s"].to_numpy() / 60.0
    for row, (c, unit) in enumerate((("accel_x", "µg"), ("gyro_x", "°/h"))):
        ax = axes[row, 0]
        ax.plot(
            t, df[f"raw_{c}"] - df[f"raw_{c}"].mean(), color=COLORS["none"], label="uncompensated"
        )
        for m in METHODS:
            y = df[f"{m}_{c}"]
            ax.plot(t, y - y.mean(), color=COLORS[m], label=LABELS[m], lw=1.0)
        ax.set_ylabel(f"{c} output − run mean [{unit}]")
        ax.set_title(f"{c}: output of the repeat cold start at 25 °C (60 s means)", fontsize=10)
        ax.grid(alpha=0.3)
        ax2 = axes[row, 1]
        ax2.plot(t, df[f"temp_{c}"], color="#444")
        for e in edges:
            if df[f"temp_{c}"].min() < e < df[f"temp_{c}"].max():
                ax2.axhline(e, color=COLORS["sectional"], ls="--", lw=0.8)
                k = int(np.argmax(df[f"temp_{c}"].to_numpy() > e))
                for a in (ax, ax2):
                    a.axvline(t[k], color=COLORS["sectional"], ls="--", lw=0.8)
        ax2.set_ylabel(f"temp_{c} [°C]")
        ax2.set_title("inner temperature; dashed: a sectional segment edge", fontsize=10)
        ax2.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8, ncol=2)
    for a in axes[1]:
        a.set_xlabel("time since power-on [min]")
    return fig


def fig_selection(cal: CalibrationResult) -> Figure:
    """Tables 5 and 7 as curves: training and held-out RMS against the setting."""
    fig = Figure(figsize=(11, 7), layout="constrained")
    axes = fig.subplots(2, 2)
    for col, method in enumerate(("regression", "neural")):
        sel = cal.selection[method].table
        for row, chans in enumerate(
            (("accel_x", "accel_y", "accel_z"), ("gyro_x", "gyro_y", "gyro_z"))
        ):
            ax = axes[row, col]
            for i, c in enumerate(chans):
                s = sel[sel["channel"] == c].sort_values("setting")
                color = f"C{i}"
                ax.plot(s["setting"], s["rms_train"], "o-", color=color, label=f"{c} train")
                ax.plot(s["setting"], s["rms_heldout"], "s--", color=color, label=f"{c} held-out")
                rec = cal.selection[method].recommended.get(c)
                if rec is not None:
                    v = s.loc[s["setting"] == rec, "rms_heldout"]
                    if len(v):
                        ax.plot([rec], [float(v.iloc[0])], "*", ms=14, color=color)
            what = "order p = q = s" if method == "regression" else "hidden neurons n"
            unit = "µg" if row == 0 else "°/h"
            ax.set_xlabel(what)
            ax.set_ylabel(f"RMS (Eq. 16, about run mean) [{unit}]")
            ax.set_title(f"{method}: training vs leave-one-run-out (★ recommended)", fontsize=10)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, ncol=2)
    return fig


def fig_nav_errors(result: NavRunResult, title: str) -> Figure:
    """Figures 9, 11, 12, 16: horizontal position error against time per variant."""
    fig = Figure(figsize=(10, 4.8), layout="constrained")
    ax = fig.subplots()
    e = result.errors
    t = e["time_s"].to_numpy() / units.HOUR_TO_S
    for v in VARIANTS:
        ax.plot(
            t,
            e[v] / units.NMI_TO_M,
            color=COLORS[v],
            ls=STYLES.get(v, "-"),
            label=LABELS[v],
            lw=1.2,
        )
    ax.set_xlabel("time since power-on [h]")
    ax.set_ylabel("horizontal position error [nmi]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=3)
    return fig


def fig_lab_bars(maxerr: pd.DataFrame) -> Figure:
    """Figure 13: maximum position error of each lab experiment and method."""
    lab = maxerr[maxerr["experiment"] == "lab"].sort_values("number")
    fig = Figure(figsize=(11, 4.5), layout="constrained")
    ax = fig.subplots()
    shown = ("none", "sectional", "regression", "neural", "poly-t")
    w = 0.8 / len(shown)
    x = np.arange(len(lab))
    for i, v in enumerate(shown):
        ax.bar(x + (i - (len(shown) - 1) / 2) * w, lab[v], w, color=COLORS[v], label=LABELS[v])
    ax.set_xticks(
        x,
        [
            f"{n}\n{s[:5]}, {a:.0f} °C"
            for n, s, a in zip(lab["number"], lab["scenario"], lab["ambient_c"], strict=True)
        ],
    )
    ax.set_ylabel("maximum horizontal position error [nmi]")
    ax.set_title(
        "Lab cold starts: experiments 1-5 quasi-static, 6-10 swing (Figure 13)", fontsize=10
    )
    ax.grid(alpha=0.3, axis="y")
    ax.legend(fontsize=8, ncol=3)
    return fig


def fig_vehicle_track(result: NavRunResult) -> Figure:
    """Figure 15: the true route and each method's INS track."""
    tr = result.track
    assert tr is not None
    fig = Figure(figsize=(8, 7), layout="constrained")
    ax = fig.subplots()
    ax.plot(
        tr["true_east_m"] / 1000,
        tr["true_north_m"] / 1000,
        color="#000",
        lw=2.2,
        label="true route (GPS stand-in)",
    )
    for v in ("none", "sectional", "regression", "neural"):
        ax.plot(
            tr[f"{v}_east_m"] / 1000,
            tr[f"{v}_north_m"] / 1000,
            color=COLORS[v],
            ls=STYLES.get(v, "-"),
            lw=1.0,
            label=LABELS[v],
        )
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east [km]")
    ax.set_ylabel("north [km]")
    ax.set_title(f"Vehicle experiment {result.job.index}: trajectories (Figure 15)", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def fig_temperatures(results: Sequence[NavRunResult]) -> Figure:
    """The thermal scenario of each navigation experiment (sensor and ambient temperature)."""
    fig = Figure(figsize=(11, 4.2), layout="constrained")
    ax = fig.subplots()
    for r in results:
        t = r.temperatures["time_s"] / units.HOUR_TO_S
        lab = f"{r.job.scenario} {r.job.index}"
        (line,) = ax.plot(t, r.temperatures["sensor_gyro_z"], lw=1.0, label=lab)
        ax.plot(t, r.temperatures["chamber"], lw=0.7, ls=":", color=line.get_color())
    ax.set_xlabel("time since power-on [h]")
    ax.set_ylabel("temperature [°C]")
    ax.set_title("Navigation runs: gyro z inner temperature (solid), ambient (dotted)", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=4)
    return fig


def _verdict(ok: bool) -> str:
    return (
        '<span class="verdict-pass">holds</span>'
        if ok
        else '<span class="verdict-fail">does not hold</span>'
    )


def build_report(
    cfg: ReproConfig,
    cal: CalibrationResult,
    nav: Sequence[NavRunResult],
    tables: Mapping[str, pd.DataFrame],
    claims: Mapping[str, Any],
    figures: Mapping[str, bytes],
    timings: Mapping[str, float],
) -> Report:
    """Assemble the report: every table and figure, the paper's numbers beside ours."""
    mode = "quick" if cfg.quick else "full"
    rep = Report(
        "rinscal: the paper's Section 5, reproduced in simulation",
        subtitle=(
            f"Wang, Cheng, Du, Sensors 2020. Mode {mode}, seed {cfg.seed}. Every number "
            "of ours comes from the simulated navigation-grade plant; none is the paper's."
        ),
    )
    s = rep.section("Summary: the paper's numbers beside ours", "summary")
    s.raw(
        '<p class="banner">All of our figures are <b>simulation</b>: a navigation-grade FOG + '
        "quartz RINS (rinscal's built-in plant), soak-calibrated as in Table 3 and navigated "
        "as in Section 5.2. The plant was written from the physics and never tuned to agree "
        "with the paper. Where we disagree, the table says so.</p>"
    )
    items = []
    for c in claims.values():
        tag = "asserted in CI" if c["asserted"] else "reported"
        items.append(
            f"<li>{_verdict(c['holds'])} ({tag}): {c['what']}: <code>{_fmt_values(c)}</code></li>"
        )
    s.raw("<h3>The paper's claims, checked on held-out data</h3><ul>" + "".join(items) + "</ul>")
    s.table("summary", tables["summary"], "The paper's headline numbers and ours")

    s = rep.section("Calibration data (Table 3, Figure 3)", "calibration-data")
    s.text(
        f"Seven soak cold starts at 0, 7, 14, 21, 28, 35, 42 °C, {cfg.soak_hours:g} h each at "
        f"{cfg.cal_rate_hz:g} Hz, no rotation; the unit had soaked before each power-on. "
        "Held out: a repetition-priming cold start at 25 °C and the −2 → 50 °C chamber ramp."
    )
    s.figure("soak", figures["soak"], "Figure 3: outputs and temperatures of the soak runs")

    s = rep.section("Method 1: sectional polynomial (Table 4)", "method1")
    for c in ("accel_x", "gyro_x"):
        s.table(
            f"table4_{c}",
            tables[f"table4_{c}"],
            f"Table 4 ({c}): coefficients per temperature segment, raw powers of T [°C] "
            "and Ṫ [°C/min], log units (µg or °/h)",
        )

    s = rep.section("Method 2: multiple regression (Tables 5, 6)", "method2")
    s.text(
        "Table 5 with an honest twist: besides the RMS on the training runs (the paper's "
        "number) we give the RMS on each run when that run was left out of the fit. RMS is "
        "Eq. 16 about each run's mean, in µg and °/h."
    )
    s.table("table5", tables["table5"], "Table 5: training and held-out RMS, orders 1-4")
    s.table("table6", tables["table6"], "Table 6: regression coefficients, raw powers, log units")

    s = rep.section("Method 3: BP neural network (Tables 7, 8)", "method3")
    s.table("table7", tables["table7"], "Table 7: training and held-out RMS, 1-8 hidden neurons")
    for c in ("accel_x", "gyro_x"):
        s.table(
            f"table8_{c}",
            tables[f"table8_{c}"],
            f"Table 8 ({c}): weights on standardised inputs and output",
        )
    s.figure("selection", figures["selection"], "Tables 5 and 7 as curves")

    s = rep.section("Held-out runs: repeat start and chamber ramp (Figures 7, 8)", "heldout")
    s.text(
        "Thermal residual: the model's prediction minus the plant's true thermal bias, each "
        "run's mean removed (a turn-on offset is not a thermal effect). The 'none' row is the "
        "true thermal bias itself. Units µg and °/h."
    )
    s.table(
        "heldout_residual", tables["heldout_residual"], "Held-out thermal residual RMS per channel"
    )
    s.table(
        "repeat_steps",
        tables["repeat_steps"],
        "Steps at the sectional segment edges on the repeat run: the model's own jump "
        "(noise-free) and the compensated output's (line fits, noisy)",
    )
    s.table(
        "ramp_steps",
        tables["ramp_steps"],
        "The same on the chamber ramp (every ramp sample lies outside the soak training range "
        "in ΔT; inputs are clamped to it)",
    )
    s.figure("repeat", figures["repeat"], "Figures 7 and 8: repeat cold start at 25 °C")

    s = rep.section("Navigation in the chamber ramp (Figure 9)", "ramp")
    s.figure("nav_ramp", figures["nav_ramp"], "Figure 9: quasi-static RINS, chamber −2 → 50 °C")

    s = rep.section("Lab cold starts: quasi-static and swing (Figures 11-13)", "lab")
    s.text(
        "Each run: cold start, self-alignment (coarse, then a Kalman filter on zero "
        f"velocity, {cfg.align_s:g} s), then free navigation with four-position modulation. "
        "All methods navigate on the same raw IMU output of a run."
    )
    s.figure("nav_qs", figures["nav_qs"], "Figure 11: quasi-static, experiment 1")
    s.figure("nav_swing", figures["nav_swing"], "Figure 12: swing, experiment 6")
    s.figure("lab_bars", figures["lab_bars"], "Figure 13: maximum errors of experiments 1-10")
    s.table("lab_max", tables["lab_max"], "Maximum horizontal position error [nmi]")

    s = rep.section("Vehicle experiments (Figures 15, 16, Table 10)", "vehicle")
    s.figure("vehicle_track", figures["vehicle_track"], "Figure 15: trajectories, run 1")
    s.figure("nav_vehicle", figures["nav_vehicle"], "Figure 16: position errors, run 1")
    s.table(
        "table10",
        tables["table10"],
        "Table 10: maximum position error [nmi] and decrease from method 1 to 3",
    )
    s.figure("temperatures", figures["temperatures"], "Thermal scenarios of the navigation runs")

    s = rep.section("What the thermal models alone cost in navigation", "thermal-part")
    s.text(
        "The maximum position error mixes the thermal-model error with what no thermal model "
        "can remove: sensor noise, the turn-on offsets and the alignment's own errors, common "
        "to every variant of a run. Because every variant navigates on the same raw output "
        "and the errors are linear, a variant's position error minus the oracle's (compensated "
        "with the true thermal bias) is the error its thermal model alone causes. Its maximum "
        "over each run, in nautical miles:"
    )
    s.table(
        "thermal_part",
        tables["thermal_part"],
        "Maximum position error caused by the thermal-model error alone [nmi]",
    )

    s = rep.section("How this was made", "method")
    rows = "".join(f"<li>{k}: {v:.1f} s</li>" for k, v in timings.items())
    s.raw(
        "<p>Command: <code>rinscal reproduce"
        + (" --quick" if cfg.quick else "")
        + f" --seed {cfg.seed}</code>. Settings:</p><ul>"
        + "".join(f"<li><code>{k} = {v}</code></li>" for k, v in vars(cfg).items())
        + f"</ul><p>Stage times:</p><ul>{rows}</ul>"
    )
    _ = PAPER
    return rep


def _fmt_values(c: Mapping[str, Any]) -> str:
    for key in ("values_ug", "values_nmi"):
        if key in c:
            v = c[key]
            if isinstance(v, dict):
                return ", ".join(f"{k}: {_num(x)}" for k, x in v.items())
            return ", ".join(_num(x) for x in v)
    return ""


def _num(x: Any) -> str:
    if isinstance(x, list | tuple):
        return "[" + ", ".join(_num(y) for y in x) + "]"
    return f"{x:.4g}" if isinstance(x, float) else str(x)


def render_figures(
    cal: CalibrationResult, nav: Sequence[NavRunResult], maxerr: pd.DataFrame
) -> dict[str, bytes]:
    """Every figure of the report as PNG bytes."""
    from rinscal.report.logplot import plot_log

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
    return {k: figure_to_png(f) for k, f in figs.items()}


__all__ = ["build_report", "render_figures", "reproduction_tables", "write_reproduction"]


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
    cal: CalibrationResult, nav: Sequence[NavRunResult]
) -> tuple[pd.DataFrame, dict[str, pd.DataFrame]]:
    """Every table of the reproduction (name -> DataFrame) and the max-error table."""
    from rinscal.experiments.paper import (
        decrease_pct,
        max_error_table,
        summary_table,
        thermal_part_table,
    )

    maxerr = max_error_table(nav)
    tables = dict(cal.tables)
    tables["lab_max"] = maxerr[maxerr["experiment"] == "lab"].drop(columns="experiment")
    veh = maxerr[maxerr["experiment"] == "vehicle"].drop(columns="experiment").copy()
    veh["decrease m1→m3 [%]"] = decrease_pct(veh["sectional"], veh["neural"])
    veh["decrease m1→m2 [%]"] = decrease_pct(veh["sectional"], veh["regression"])
    tables["table10"] = veh
    tables["ramp_max"] = maxerr[maxerr["experiment"] == "ramp"].drop(columns="experiment")
    tables["summary"] = summary_table(cal, maxerr)
    tables["thermal_part"] = thermal_part_table(nav)
    return maxerr, tables


def write_reproduction(
    out: Path,
    cfg: ReproConfig,
    cal: CalibrationResult,
    nav: Sequence[NavRunResult],
    timings: Mapping[str, float],
) -> Written:
    """Write report.html, figures/*.png, tables/*.csv, models/*.json and metrics.json."""
    import json

    from rinscal.experiments.paper import claims
    from rinscal.io import write_atomic

    maxerr, tables = reproduction_tables(cal, nav)
    checked = claims(cal, maxerr, tables["thermal_part"])
    figures = render_figures(cal, nav, maxerr)
    for sub in ("figures", "tables", "models"):
        (out / sub).mkdir(parents=True, exist_ok=True)
    for name, png in figures.items():
        write_atomic(out / "figures" / f"{name}.png", lambda tmp, png=png: tmp.write_bytes(png))
    for name, df in tables.items():
        write_atomic(out / "tables" / f"{name}.csv", lambda tmp, df=df: df.to_csv(tmp, index=False))
    for m, model in cal.models.items():
        model.save(out / "models" / f"{m}.json")
    rep = build_report(cfg, cal, nav, tables, checked, figures, timings)
    page = rep.to_html()
    write_atomic(out / "report.html", lambda tmp: tmp.write_text(page, encoding="utf-8"))
    metrics = {
        "mode": "quick" if cfg.quick else "full",
        "config": {k: (list(v) if isinstance(v, tuple) else v) for k, v in vars(cfg).items()},
        "claims": checked,
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
        "heldout_residual": tables["heldout_residual"].to_dict(orient="records"),
        "repeat_steps": tables["repeat_steps"].to_dict(orient="records"),
        "summary": tables["summary"].to_dict(orient="records"),
        "selection": {m: s.to_dict() for m, s in cal.selection.items()},
    }
    text = json.dumps(metrics, indent=2, default=_json_default) + "\n"
    write_atomic(out / "metrics.json", lambda tmp: tmp.write_text(text))
    return Written(out, maxerr, tables)


def _json_default(obj: object) -> object:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")
