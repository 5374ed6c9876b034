"""Figures of a navigation run, after the paper's Figures 9, 11, 12, 15 and 16.

* :func:`plot_position_error` — horizontal position error [nmi] against time [h], one line
  per compensation variant (Figures 9, 11, 12, 16).
* :func:`plot_trajectory` — east/north track of the truth and of the INS of each variant,
  in km from the start (Figure 15).
* :func:`plot_temperatures` — chamber/ambient, outer and inner sensor temperatures of the
  thermal scenario that ran alongside.
* :func:`navigation_figures` — the three above of a navigation, by file name;
  :func:`save_navigation` writes a navigation's whole folder with them.

Functions return a :class:`matplotlib.figure.Figure` (no pyplot state); the caller saves.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from rinscal import earth, units
from rinscal.nav.engine import Navigation, NavResult

_STYLES = {"none": ("0.35", "--"), "true": ("black", ":")}
_LABELS = {"none": "uncompensated", "true": "true thermal bias (oracle)"}


def _label(name: str) -> str:
    return _LABELS.get(name, name)


def _style(name: str, k: int) -> dict[str, object]:
    if name in _STYLES:
        c, ls = _STYLES[name]
        return {"color": c, "linestyle": ls}
    return {"color": f"C{k}", "linestyle": "-"}


def plot_position_error(result: NavResult, title: str | None = None) -> Figure:
    """Horizontal position error [nmi] of each variant against time [h]."""
    fig = Figure(figsize=(8.0, 4.6), layout="constrained")
    ax = fig.add_subplot()
    c = result.config
    t0 = float(getattr(c, "time_origin_s", 0.0))  # a recording's clock may not start at 0
    for k, (name, df) in enumerate(result.errors.items()):
        t = (df["time_s"].to_numpy() - t0) / units.HOUR_TO_S
        h = df["horizontal_nmi"].to_numpy()
        mx = float(h.max()) if h.size else float("nan")
        ax.plot(t, h, lw=1.3, label=f"{_label(name)} (max {mx:.3f} nmi)", **_style(name, k))
    ax.set_xlabel("time since power-on [h]")
    ax.set_ylabel("horizontal position error [nmi]")
    sec = ax.secondary_yaxis(
        "right",
        functions=(lambda x: x * units.NMI_TO_M / 1000, lambda x: x * 1000 / units.NMI_TO_M),
    )
    sec.set_ylabel("[km]")
    start = (c.nav_start_s - t0) / units.HOUR_TO_S
    align0 = (c.align_start_s - t0) / units.HOUR_TO_S
    # shade the warm-up before the alignment (if any) and the alignment itself
    for lo, hi, tag, shade in ((0.0, align0, "warm-up", "0.96"), (align0, start, "align", "0.9")):
        if hi > lo:
            ax.axvspan(lo, hi, color=shade, lw=0)
            ax.text(0.5 * (lo + hi), 0.02, tag, transform=ax.get_xaxis_transform(),
                    ha="center", va="bottom", rotation=90, fontsize=8)  # fmt: skip
    ax.set_xlim(0, c.duration_s / units.HOUR_TO_S)
    ax.set_ylim(bottom=0)
    ax.grid(True, lw=0.4, alpha=0.6)
    ax.legend(fontsize=8, loc="upper left")
    ax.set_title(title or f"{c.name}: position error ({c.schedule.name})", fontsize=10)
    return fig


def _local_km(
    lat_deg: np.ndarray, lon_deg: np.ndarray, lat0: float, lon0: float
) -> tuple[np.ndarray, np.ndarray]:
    rn, re = earth.principal_radii(lat0)
    e = (np.deg2rad(lon_deg) - lon0) * float(re) * np.cos(lat0) / 1000.0
    n = (np.deg2rad(lat_deg) - lat0) * float(rn) / 1000.0
    return e, n


def plot_trajectory(result: NavResult, title: str | None = None) -> Figure:
    """East/north track of the truth and of each variant's INS [km from the start]."""
    fig = Figure(figsize=(6.4, 6.0), layout="constrained")
    ax = fig.add_subplot()
    tr = result.config.trajectory
    lat0, lon0 = tr.lat0, tr.lon0
    te, tn = _local_km(
        result.truth["lat_deg"].to_numpy(), result.truth["lon_deg"].to_numpy(), lat0, lon0
    )
    ax.plot(te, tn, color="C2", lw=2.2, alpha=0.6, label="truth (GPS stand-in)")
    for k, (name, df) in enumerate(result.errors.items()):
        e, n = _local_km(df["lat_deg"].to_numpy(), df["lon_deg"].to_numpy(), lat0, lon0)
        ax.plot(e, n, lw=1.0, label=_label(name), **_style(name, k))
    ax.plot([0], [0], "k^", ms=7, label="start")
    ax.set_xlabel("east [km]")
    ax.set_ylabel("north [km]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.4, alpha=0.6)
    ax.legend(fontsize=8)
    ax.set_title(title or f"{result.config.name}: trajectories", fontsize=10)
    return fig


def plot_temperatures(temps: pd.DataFrame, title: str | None = None) -> Figure:
    """Temperatures of the thermal scenario.

    Parameters
    ----------
    temps : pandas.DataFrame
        ``time_s``, ``chamber``, ``outer`` and one ``sensor_<channel>`` column per sensor
        [s, °C].
    """
    fig = Figure(figsize=(8.0, 3.8), layout="constrained")
    ax = fig.add_subplot()
    t = temps["time_s"].to_numpy() / units.HOUR_TO_S
    ax.plot(t, temps["chamber"], color="0.4", ls="--", label="ambient / chamber")
    ax.plot(t, temps["outer"], color="black", label="outer (package)")
    for k, col in enumerate(c for c in temps.columns if c.startswith("sensor_")):
        ax.plot(t, temps[col], lw=0.9, color=f"C{k}", label=col.removeprefix("sensor_"))
    ax.set_xlabel("time since power-on [h]")
    ax.set_ylabel("temperature [°C]")
    ax.grid(True, lw=0.4, alpha=0.6)
    ax.legend(fontsize=7, ncol=3)
    ax.set_title(title or "thermal field", fontsize=10)
    return fig


def navigation_figures(nav: Navigation, skip: tuple[str, ...] = ()) -> dict[str, Figure]:
    """The figures of a navigation's folder, by file name: ``position_error.png``,
    ``trajectory.png`` and ``temperatures.png`` (what ``rinscal navigate`` writes), less
    those named in ``skip`` (drawn already)."""
    makers = {
        "position_error.png": lambda: plot_position_error(nav.result),
        "trajectory.png": lambda: plot_trajectory(nav.result),
        "temperatures.png": lambda: plot_temperatures(nav.temperatures),
    }
    return {name: make() for name, make in makers.items() if name not in skip}


def save_navigation(
    nav: Navigation, folder: str | os.PathLike[str], n_jobs: int | None = 1
) -> Path:
    """Write a navigation's folder as ``rinscal navigate`` does: ``errors.csv``,
    ``truth.csv``, ``summary.json`` and the figures of :func:`navigation_figures`
    (:meth:`rinscal.nav.engine.Navigation.save`; ``n_jobs`` threads, the figures drawn
    while the CSV files are formatted). Returns the folder."""
    return nav.save(folder, figures=navigation_figures, n_jobs=n_jobs)


__all__ = [
    "navigation_figures",
    "plot_position_error",
    "plot_temperatures",
    "plot_trajectory",
    "save_navigation",
]
