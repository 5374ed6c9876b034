"""Figures of ``rinscal reproduce``: the paper's Figures 7-9, 11-13, 15 and 16 and the order
and neuron tables, drawn from the data the experiments returned (matplotlib Figures, no pyplot
state; nothing is computed or written here)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from matplotlib import colormaps
from matplotlib.figure import Figure

from rinscal import units
from rinscal.experiments.paper.calibration import CalibrationResult
from rinscal.experiments.paper.config import LABELS, METHODS, VARIANTS
from rinscal.experiments.paper.navigation import NavRunResult

__all__ = [
    "COLORS",
    "STYLES",
    "VARIANT_STYLE",
    "fig_heading_velocity",
    "fig_lab_bars",
    "fig_nav_errors",
    "fig_repeat",
    "fig_selection",
    "fig_temperatures",
    "fig_vehicle_track",
]

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
    """Figures 7 and 8: x-axis outputs of the repeat run before and after compensation
    (60 s means), the noise-free thermal residual of each model (where a segment edge's
    step shows without the sensor noise) and the inner temperature."""
    df = cal.repeat_curves
    assert df is not None
    edges = np.asarray(cal.models["sectional"].models["accel_x"].segment_edges, dtype=float)
    has_resid = any(k.startswith("resid_") for k in df.columns)
    ncol = 3 if has_resid else 2
    fig = Figure(figsize=(13 if has_resid else 11, 6.5), layout="constrained")
    axes = fig.subplots(2, ncol, sharex=True)
    t = df["time_s"].to_numpy() / 60.0
    for row, (c, unit) in enumerate((("accel_x", "µg"), ("gyro_x", "°/h"))):
        ax = axes[row, 0]
        ax.plot(
            t, df[f"raw_{c}"] - df[f"raw_{c}"].mean(), color=COLORS["none"], label="uncompensated"
        )
        for m in METHODS:
            y = df[f"{m}_{c}"]
            ax.plot(t, y - y.mean(), color=COLORS[m], label=LABELS[m], lw=1.0)
        ax.set_ylabel(f"output − run mean [{unit}]")
        ax.set_title(f"{c}: output, 60 s means (noisy)", fontsize=10)
        ax.grid(alpha=0.3)
        marks = [ax]
        if has_resid:
            axr = axes[row, 1]
            late = t > 10.0  # the first minutes' transient would hide a step of a few µg
            span = []
            for m in METHODS:
                y = df[f"resid_{m}_{c}"]
                y = (y - y.mean()).to_numpy()
                axr.plot(t, y, color=COLORS[m], label=LABELS[m], lw=1.2)
                span.append(y[late & np.isfinite(y)])
            both = np.concatenate(span) if span else np.zeros(0)
            if both.size:
                lo, hi = float(both.min()), float(both.max())
                pad = 0.1 * (hi - lo) or 1.0
                axr.set_ylim(lo - pad, hi + pad)
            axr.set_ylabel(f"model − true bias, run mean removed [{unit}]")
            axr.set_title(f"{c}: thermal residual, noise-free (y range from 10 min)", fontsize=10)
            axr.grid(alpha=0.3)
            marks.append(axr)
        ax2 = axes[row, ncol - 1]
        ax2.plot(t, df[f"temp_{c}"], color="#444")
        marks.append(ax2)
        for e in edges:
            if df[f"temp_{c}"].min() < e < df[f"temp_{c}"].max():
                ax2.axhline(e, color=COLORS["sectional"], ls="--", lw=0.8)
                k = int(np.argmax(df[f"temp_{c}"].to_numpy() > e))
                for a in marks:
                    a.axvline(t[k], color=COLORS["sectional"], ls="--", lw=0.8)
        ax2.set_ylabel(f"inner temperature, {c} [°C]")
        ax2.set_title("dashed: a sectional segment edge", fontsize=10)
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
            key = ("table5_" if method == "regression" else "table7_") + (
                "accel" if row == 0 else "gyro"
            )
            floor = cal.tables.get(key)
            if floor is not None and len(floor):
                ax.axhline(
                    float(floor["noise floor"].iloc[0]),
                    color="#444",
                    ls=":",
                    lw=1.2,
                    label="noise floor",
                )
            what = "order p = q = s" if method == "regression" else "hidden neurons n"
            unit = "µg" if row == 0 else "°/h"
            ax.set_xlabel(what)
            # an order or a neuron count is a whole number: ticks at the settings tried
            ax.set_xticks(sorted({int(x) for x in sel["setting"]}))
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
    # one colour family per kind of run, a shade per run: 14 runs, no colour used twice
    family = {"ramp": "Greys", "quasi-static": "Blues", "swing": "Oranges", "vehicle": "Greens"}
    count = {k: sum(r.job.scenario == k for r in results) for k in family}
    seen = dict.fromkeys(family, 0)
    for r in results:
        t = r.temperatures["time_s"] / units.HOUR_TO_S
        lab = f"{r.job.scenario} {r.job.index}"
        kind = r.job.scenario if r.job.scenario in family else "ramp"
        shade = 0.45 + 0.5 * seen[kind] / max(count[kind] - 1, 1)
        seen[kind] += 1
        color = colormaps[family[kind]](shade)
        ax.plot(t, r.temperatures["sensor_gyro_z"], lw=1.1, label=lab, color=color)
        ax.plot(t, r.temperatures["chamber"], lw=0.7, ls=":", color=color)
    ax.set_xlabel("time since power-on [h]")
    ax.set_ylabel("temperature [°C]")
    ax.set_title("Navigation runs: gyro z inner temperature (solid), ambient (dotted)", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=4)
    return fig


#: Colour and line style of every navigation variant in the mechanism figure (the oracle
#: without turn-on offsets included); each variant has its own pair.
VARIANT_STYLE = {
    "none": ("#7f7f7f", "--"),
    "poly-t": ("#9467bd", "-."),
    "sectional": ("#d62728", (0, (5, 1))),
    "regression": ("#1f77b4", "-"),
    "neural": ("#2ca02c", (0, (3, 1, 1, 1))),
    "true": ("#000000", ":"),
    "true-no-offsets": ("#e377c2", (0, (1, 1))),
}


def fig_heading_velocity(results: Sequence[NavRunResult], labels: dict[str, str]) -> Figure:
    """Heading error and horizontal velocity error against time per variant, one row per
    run given (the report passes the first quasi-static and the first vehicle run)."""
    fig = Figure(figsize=(10.5, 3.3 * max(1, len(results)) + 0.6), layout="constrained")
    axes = np.atleast_2d(fig.subplots(max(1, len(results)), 2, squeeze=False))
    handles = {}
    for row, r in enumerate(results):
        e = r.errors
        t = e["time_s"].to_numpy() / units.HOUR_TO_S
        for v, (color, ls) in VARIANT_STYLE.items():
            if f"{v}_heading" not in e:
                continue
            kw = {"color": color, "ls": ls, "lw": 1.1}
            (h,) = axes[row, 0].plot(t, e[f"{v}_heading"] / units.ARCSEC_TO_RAD, **kw)
            axes[row, 1].plot(t, np.hypot(e[f"{v}_ve"], e[f"{v}_vn"]), **kw)
            handles[v] = h
        name = f"{r.job.scenario} {r.job.index}"
        axes[row, 0].set_ylabel("heading error [″]")
        axes[row, 0].set_title(f"{name}: heading error (INS − truth)", fontsize=10)
        axes[row, 1].set_ylabel("horizontal velocity error [m/s]")
        axes[row, 1].set_title(f"{name}: |velocity error|", fontsize=10)
        for a in axes[row]:
            a.grid(alpha=0.3)
    for a in axes[-1]:
        a.set_xlabel("time since power-on [h]")
    fig.legend(
        list(handles.values()),
        [labels.get(v, v) for v in handles],
        loc="outside lower center",
        ncol=4,
        fontsize=8,
    )
    return fig
