"""The paper's Figure 3: IMU outputs and temperatures against time, one colour per run.

Large logs (millions of samples) are decimated per run for display: each bin of ``k``
consecutive samples is drawn as its mean (the thermal trend, which white noise would hide)
over a light band from its minimum to its maximum (so every extreme, outliers included,
stays visible), and the figure draws in about a second. The axes titles say when this was
done.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
from matplotlib import colormaps
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import FuncFormatter

from rinscal.io.mapping import channel_unit
from rinscal.schema import (
    ACCEL_CHANNELS,
    CHAMBER,
    CHANNELS,
    GYRO_CHANNELS,
    RUN,
    TEMP_IN,
    TEMP_OUT,
    TIME,
    temp_column,
)

#: Display names of unit strings used in logs and metadata.
_PRETTY_UNITS = {
    "ug": "µg",
    "mg": "mg",
    "deg/h": "°/h",
    "deg/s": "°/s",
    "m/s^2": "m/s²",
    "m/s2": "m/s²",
    "pulse": "pulses",
    "pulses": "pulses",
}
_AXIS_STYLES = {"x": "-", "y": "--", "z": ":"}


def pretty_unit(unit: str | None) -> str:
    """Unit name for an axis label (``"ug"`` -> ``"µg"``); ``"log units"`` when unknown."""
    if not unit:
        return "log units"
    return _PRETTY_UNITS.get(unit, unit)


def units_from_meta(meta: Mapping[str, Any] | None) -> dict[str, str]:
    """Channel units recorded in a log's sidecar metadata.

    Parameters
    ----------
    meta : mapping or None
        Metadata as read by :func:`rinscal.io.metadata.read_meta`.

    Returns
    -------
    dict of str to str
        Channel -> unit name, e.g. ``{"gyro_x": "deg/h", ...}``, for every channel whose
        unit the metadata gives, per channel or per sensor (``{"gyro": "rad/s"}``, as a
        flight log's); empty when unknown.
    """
    if not meta or not isinstance(meta.get("units"), Mapping):
        return {}
    units = {ch: channel_unit(meta["units"], ch) for ch in CHANNELS}
    return {ch: u for ch, u in units.items() if u is not None}


class Decimated(NamedTuple):
    """A signal reduced to bins for display (see :func:`decimate`)."""

    #: Bin mid times, shape (p,) [same unit as the input times].
    t: np.ndarray
    #: Minimum of each bin, shape (p,) or (p, m).
    lo: np.ndarray
    #: Mean of each bin (NaN ignored), shape (p,) or (p, m).
    mean: np.ndarray
    #: Maximum of each bin, shape (p,) or (p, m).
    hi: np.ndarray
    #: Samples per bin (the last bin may hold fewer); 1 when nothing was reduced.
    step: int


def decimate(t: np.ndarray, y: np.ndarray, max_bins: int) -> Decimated:
    """Reduce a signal to at most ``max_bins`` bins of consecutive samples for display.

    Each bin keeps its minimum, mean and maximum, so a plot of the mean shows the slow
    (thermal) trend that white noise would otherwise hide, and the min/max band keeps every
    extreme value (outliers included) visible.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Sample times (increasing).
    y : ndarray, shape (n,) or (n, m)
        Values; NaN (dropped samples) are ignored within a bin, an all-NaN bin stays NaN.
    max_bins : int
        Most bins to return (at least 1).

    Returns
    -------
    Decimated
        Bin mid times and per-bin minimum, mean and maximum; the input itself (``lo``,
        ``mean`` and ``hi`` all ``y``, ``step`` 1) when ``n <= max_bins``.
    """
    t = np.asarray(t, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    n = t.shape[0]
    if n <= max_bins:
        return Decimated(t, y, y, y, 1)
    step = -(-n // max(1, max_bins))  # ceil
    starts = np.arange(0, n, step)
    ends = np.minimum(starts + step, n)
    valid = ~np.isnan(y)
    total = np.add.reduceat(np.where(valid, y, 0.0), starts, axis=0)
    count = np.add.reduceat(valid.astype(np.int64), starts, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(count > 0, total / np.maximum(count, 1), np.nan)
    lo = np.fmin.reduceat(y, starts, axis=0)
    hi = np.fmax.reduceat(y, starts, axis=0)
    t_mid = 0.5 * (t[starts] + t[ends - 1])
    return Decimated(t_mid, lo, mean, hi, step)


def _run_rows(codes: np.ndarray, n_runs: int) -> list[slice | np.ndarray]:
    """Rows of each run: a slice when runs are contiguous blocks (no copy), else indices."""
    change = np.flatnonzero(codes[1:] != codes[:-1]) + 1
    if change.size + 1 == n_runs:
        edges = [0, *change.tolist(), len(codes)]
        return [slice(edges[k], edges[k + 1]) for k in range(n_runs)]
    order = np.argsort(codes, kind="stable")
    bounds = np.searchsorted(codes[order], np.arange(n_runs + 1))
    return [order[bounds[k] : bounds[k + 1]] for k in range(n_runs)]


def _time_scale(t_max: float) -> tuple[float, str]:
    if t_max > 3 * 3600.0:
        return 3600.0, "h"
    if t_max > 3 * 60.0:
        return 60.0, "min"
    return 1.0, "s"


def _run_colors(n: int) -> list[Any]:
    if n <= 10:
        return [colormaps["tab10"](i) for i in range(n)]
    return [colormaps["viridis"](x) for x in np.linspace(0.0, 0.95, n)]


def _temperature_panels(df: pd.DataFrame) -> list[tuple[str, list[tuple[str, str, str]]]]:
    """Panels of the temperature row: (title, [(column, label, linestyle), ...])."""
    panels: list[tuple[str, list[tuple[str, str, str]]]] = []
    for title, chans in (
        ("inner temperature, gyros", GYRO_CHANNELS),
        ("inner temperature, accelerometers", ACCEL_CHANNELS),
    ):
        lines = [
            (temp_column(c), temp_column(c), _AXIS_STYLES[c[-1]])
            for c in chans
            if temp_column(c) in df.columns
        ]
        if lines:
            panels.append((title, lines))
    if TEMP_IN in df.columns and len(panels) < 2:
        panels.insert(0, ("inner temperature (shared)", [(TEMP_IN, TEMP_IN, "-")]))
    outer = [
        (c, lab, ls)
        for c, lab, ls in ((TEMP_OUT, "outer", "-"), (CHAMBER, "chamber", "--"))
        if c in df.columns
    ]
    if outer:
        panels.append(("outer and chamber temperature", outer))
    return panels[:3]


def _relative_ticks(ax: Any, what: str, unit: str) -> None:
    """Where the values sit far from zero compared with their span (an accelerometer's 1 g
    beside a drift of a few hundred µg), label the ticks as differences from a round
    reference named in the axis label, instead of matplotlib's detached "1e6" offset."""
    lo, hi = ax.get_ylim()
    span = hi - lo
    mid = 0.5 * (lo + hi)
    if span <= 0 or abs(mid) < 100 * span:
        ax.set_ylabel(f"{what} [{unit}]")
        return
    step = 10.0 ** np.floor(np.log10(span))
    ref = float(np.round(mid / step) * step)
    ax.yaxis.set_major_formatter(
        FuncFormatter(lambda y, _pos: f"{y - ref:+.4g}" if y != ref else "0")
    )
    ax.set_ylabel(
        f"{what} − {ref:,.0f} [{unit}]" if abs(ref) >= 1 else f"{what} − {ref:g} [{unit}]"
    )


def plot_log(
    df: pd.DataFrame,
    *,
    units: Mapping[str, str] | None = None,
    title: str | None = None,
    max_bins: int = 1000,
    figsize: tuple[float, float] = (15.0, 10.0),
) -> Figure:
    """Draw a calibration log: the six outputs and the temperatures against time per run.

    The paper's Figure 3 (accelerometer and gyroscope outputs at the chamber set points),
    with the temperature field below it: row 1 the accelerometers, row 2 the gyroscopes,
    row 3 the inner temperatures (per channel, or shared) and the outer and chamber
    temperatures. One colour per run; time since power-on on the x axes.

    Parameters
    ----------
    df : DataFrame
        A validated calibration log (:func:`rinscal.schema.validate_log`).
    units : mapping of str to str, optional
        Channel -> unit of its values in the log (e.g. from :func:`units_from_meta`);
        channels without one are labelled "log units".
    title : str, optional
        Figure title.
    max_bins : int
        Most points drawn per run and line; a longer run is reduced to this many bins of
        consecutive samples (:func:`decimate`) and drawn as the bin means with a light
        min/max band, so thermal trends show through the noise and no extreme is hidden;
        the axes titles say so.
    figsize : tuple of float
        Figure size [inch].

    Returns
    -------
    matplotlib.figure.Figure
        The figure, not yet saved.
    """
    units = dict(units or {})
    fig = Figure(figsize=figsize, layout="constrained")
    axes = fig.subplots(3, 3, sharex=True, squeeze=False)

    codes, run_names = pd.factorize(df[RUN], sort=False)
    colors = _run_colors(len(run_names))
    t_all = df[TIME].to_numpy(dtype=np.float64)
    scale, t_unit = _time_scale(float(np.max(t_all)) if len(t_all) else 0.0)

    sensor_cols = [*ACCEL_CHANNELS, *GYRO_CHANNELS]
    temp_panels = _temperature_panels(df)
    temp_cols = [c for _, lines in temp_panels for c, _, _ in lines]
    columns = [df[c].to_numpy(dtype=np.float64) for c in sensor_cols + temp_cols]  # views

    max_step = 1
    # y limits follow the bin means (the thermal trend), not rare outliers in the band
    mean_lo = np.full(len(sensor_cols), np.inf)
    mean_hi = np.full(len(sensor_cols), -np.inf)
    for k, rows in enumerate(_run_rows(codes, len(run_names))):
        t_run = t_all[rows]
        drawn = [decimate(t_run, y[rows], max_bins) for y in columns]
        td = drawn[0].t / scale
        max_step = max(max_step, drawn[0].step)
        for j, d in enumerate(drawn[: len(sensor_cols)]):
            ax = axes[j // 3, j % 3]
            if d.step > 1:
                ax.fill_between(td, d.lo, d.hi, color=colors[k], alpha=0.06, lw=0.0)
            ax.plot(td, d.mean, color=colors[k], lw=0.9)
            if np.any(np.isfinite(d.mean)):
                mean_lo[j] = min(mean_lo[j], float(np.nanmin(d.mean)))
                mean_hi[j] = max(mean_hi[j], float(np.nanmax(d.mean)))
        j = len(sensor_cols)
        for p, (_, lines) in enumerate(temp_panels):
            for _col, _lab, ls in lines:
                axes[2, p].plot(td, drawn[j].mean, color=colors[k], lw=1.0, ls=ls)
                j += 1

    note = ""
    if max_step > 1:
        note = f"\n(decimated: means of ≤{max_step:,} samples)"
    for j, ch in enumerate(sensor_cols):
        ax = axes[j // 3, j % 3]
        unit = pretty_unit(units.get(ch))
        kind = "accelerometer" if ch in ACCEL_CHANNELS else "gyroscope"
        ax.set_title(f"{ch} ({kind}){note}", fontsize=10)
        ax.set_ylabel(f"{ch} output [{unit}]")
        if max_step > 1 and np.isfinite(mean_lo[j]) and mean_hi[j] >= mean_lo[j]:
            pad = 0.15 * (mean_hi[j] - mean_lo[j]) or 1e-9 * max(1.0, abs(mean_hi[j]))
            ax.set_ylim(mean_lo[j] - pad, mean_hi[j] + pad)
        _relative_ticks(ax, f"{ch} output", unit)
        ax.grid(True, alpha=0.3)
    for p, (ptitle, lines) in enumerate(temp_panels):
        ax = axes[2, p]
        ax.set_title(
            ptitle + note,
            fontsize=10,
        )
        ax.set_ylabel("temperature [°C]")
        ax.grid(True, alpha=0.3)
        if len(lines) > 1:
            handles = [Line2D([], [], color="0.3", ls=ls, label=lab) for _, lab, ls in lines]
            ax.legend(handles=handles, fontsize=8, loc="best")
    for p in range(len(temp_panels), 3):
        axes[2, p].set_axis_off()
    for ax in axes[-1]:
        ax.set_xlabel(f"time since power-on [{t_unit}]")
        ax.xaxis.set_tick_params(labelbottom=True)
    if len(temp_panels) < 3:  # the axes above an empty panel carry the time labels
        for p in range(len(temp_panels), 3):
            axes[1, p].set_xlabel(f"time since power-on [{t_unit}]")
            axes[1, p].xaxis.set_tick_params(labelbottom=True)

    handles = [
        Line2D([], [], color=colors[k], lw=2.0, label=str(name)) for k, name in enumerate(run_names)
    ]
    fig.legend(
        handles=handles,
        loc="outside lower center",
        ncols=min(len(handles), 8),
        title=f"run ({len(run_names)})",
        fontsize=9,
    )
    n = len(df)
    head = title or "Calibration log"
    fig.suptitle(f"{head}: {len(run_names)} run(s), {n:,} samples", fontsize=12)
    return fig
