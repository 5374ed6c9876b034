"""The fleet's HTML report: verdicts, and every unit's figures across the fleet.

Built from :class:`rinscal.production.fleet.FleetReport` (no file is read here): the verdict
per unit (pass, fail with the limits exceeded, failed with the error), a figure of the held-out
residual, thermal span and noise density of every unit per channel, and the distribution table
of every figure and coefficient across units.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from rinscal import units
from rinscal.calibration.allan_units import datasheet_units
from rinscal.report.html import Report, figure_to_png, format_sig

__all__ = ["FIGURES", "distribution_view", "fleet_figure", "fleet_html", "physical_figures"]

#: The per-channel figures drawn, with their labels.
FIGURES: dict[str, str] = {
    "heldout_rms": "held-out RMS (training RMS if not auto)",
    "thermal_span": "modelled thermal span",
    "noise_density": "white-noise density (ARW, VRW)",
}


def physical_figures(figures: pd.DataFrame) -> pd.DataFrame:
    """``FleetReport.figures`` (or its distribution) with every unit in words and the
    white-noise density in its data-sheet unit (:func:`rinscal.calibration.allan_units.
    datasheet_units`: a gyro's in °/√h, an accelerometer's in µg/√Hz; the limits and CSV
    files keep the log's unit·√s). Value columns: ``value`` or ``mean, sd, min, median,
    max``."""
    out = figures.copy()
    cols = [c for c in ("value", "mean", "sd", "min", "median", "max") if c in out]
    noise = out["name"] == "noise_density"
    for i in out.index[noise]:
        u = datasheet_units(str(out.at[i, "unit_of"]))
        out.loc[i, cols] = out.loc[i, cols].astype(float) * u.n_factor
        out.at[i, "unit_of"] = u.n_unit
    out["unit_of"] = [units.unit_words(str(u)) for u in out["unit_of"]]
    return out


def distribution_view(dist: pd.DataFrame) -> pd.DataFrame:
    """The distribution across units for the page: each figure and coefficient named in
    words with its physical unit, every number to 3 significant digits of its own row (the
    rows mix °/h, µg and their coefficients: one column format would round the gyros' to
    0)."""
    d = physical_figures(dist)
    words = {k: v.split(" (")[0] for k, v in FIGURES.items()}
    return pd.DataFrame(
        {
            "channel": d["channel"].to_numpy(),
            "model": d["model"].to_numpy(),
            "figure or coefficient": [words.get(n, n) for n in d["name"]],
            "unit": d["unit_of"].to_numpy(),
            "units": d["n"].astype(int).to_numpy(),
            **{k: [format_sig(x, 3) for x in d[k]] for k in ("mean", "sd", "min", "median", "max")},
        }
    )


def fleet_figure(figures: pd.DataFrame) -> Any:
    """Every unit's figures, per channel: rows gyro / accel, columns :data:`FIGURES`.

    Parameters
    ----------
    figures : DataFrame
        ``FleetReport.figures`` (long form).

    Returns
    -------
    matplotlib.figure.Figure
    """
    # deferred: matplotlib loads in ~0.3 s; the report's tables do not need it
    from matplotlib.figure import Figure

    figures = physical_figures(figures)
    fig = Figure(figsize=(11, 6), layout="constrained")
    axes = fig.subplots(2, len(FIGURES), squeeze=False)
    for i, sensor in enumerate(("gyro", "accel")):
        for k, (name, label) in enumerate(FIGURES.items()):
            ax = axes[i][k]
            part = figures[figures["channel"].str.startswith(sensor) & (figures["name"] == name)]
            chans = sorted(part["channel"].unique())
            for x, c in enumerate(chans):
                v = part.loc[part["channel"] == c, "value"].to_numpy(dtype=np.float64)
                v = v[np.isfinite(v)]
                jitter = np.linspace(-0.15, 0.15, v.size) if v.size > 1 else np.zeros(v.size)
                ax.plot(x + jitter, v, "o", ms=4, alpha=0.7)
            ax.set_xticks(range(len(chans)), chans)
            unit = part["unit_of"].iloc[0] if len(part) else ""
            ax.set_title(f"{sensor}: {label}" + (f" [{unit}]" if unit else ""), fontsize=10)
            finite = part["value"].to_numpy(dtype=np.float64)
            finite = finite[np.isfinite(finite)]  # no held-out RMS without auto: all NaN
            if finite.size and finite.min() > 0:
                ax.set_yscale("log")
            ax.grid(alpha=0.3)
    return fig


def fleet_html(report: Any, limits_source: str, options: dict[str, Any]) -> str:
    """The fleet's report as one self-contained HTML page.

    Parameters
    ----------
    report : FleetReport
        From :func:`rinscal.production.fleet.fleet_report`.
    limits_source : str
        Where the limits came from (a file name, or that none were given).
    options : dict
        The fit options (method, export).

    Returns
    -------
    str
    """
    v = report.verdicts
    counts = v["verdict"].value_counts()
    page = Report(
        "rinscal fleet calibration",
        f"{len(v)} unit(s): {counts.get('pass', 0)} pass, {counts.get('fail', 0)} fail, "
        f"{counts.get('failed', 0)} failed to fit; method {options.get('method')}, limits "
        f"{limits_source}",
    )
    s = page.section("Verdicts", "verdicts")
    s.text(
        "pass: every channel within the limits; fail: the limits it exceeds; failed: the log "
        "could not be read or fitted (the error). Without limits every fitted unit passes."
    )
    s.table("verdicts", v, "verdict per unit")
    if not report.figures.empty:
        s = page.section("Across the fleet", "fleet")
        s.figure(
            "fleet",
            figure_to_png(fleet_figure(report.figures)),
            "each point a unit: held-out RMS, modelled thermal span and noise density per channel",
        )
        s.table(
            "distribution",
            distribution_view(report.distribution),
            "Every figure and coefficient across units, per channel and model: mean, sample "
            "sd over the units, min, median and max, in physical units (the coefficients of "
            "the model's polynomial in T [°C], Ṫ [°C/min] and ΔT [°C]; distribution.csv "
            "holds the same, with the white-noise density in the log's unit·√s as the limits)",
        )
    return page.to_html()
