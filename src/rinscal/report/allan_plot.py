"""Allan deviation figure: one log-log panel per channel, raw and compensated overlaid.

:func:`allan_figure` draws the curves of :func:`rinscal.calibration.allan.allan_deviation`
with their 1σ band, the IEEE Std 952 noise parameters of each curve in the legend, and the
slope −1/2 (angle/velocity random walk) and +1/2 (rate random walk) reference lines dotted:
the fitted lines of the first curve of the panel where it has those regions
(``σ = N/√τ``, ``σ = K √(τ/3)``), otherwise guides through its first point and its
minimum. The τ at which the bias instability was read is marked with an open circle.

Returns a :class:`matplotlib.figure.Figure` (no pyplot state); the caller saves.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from rinscal.calibration.allan import (
    BIAS_INSTABILITY_FACTOR,
    AllanCurve,
    NoiseParameters,
    noise_parameters,
)
from rinscal.errors import ConfigError
from rinscal.report.logplot import pretty_unit

__all__ = ["allan_figure"]

_REF_STYLE = {"color": "0.25", "linestyle": ":", "lw": 1.1}


def _fmt(x: float) -> str:
    return f"{x:.3g}"


def _legend_label(label: str, p: NoiseParameters, unit: str) -> str:
    parts = []
    if p.n is not None:
        parts.append(f"N {_fmt(p.n)} {unit}·√s")
    if p.b is not None:
        parts.append(f"B {_fmt(p.b)} {unit}")
    if p.k is not None:
        parts.append(f"K {_fmt(p.k)} {unit}/√s")
    return f"{label}: " + ", ".join(parts) if parts else label


def _panel(ax: Axes, channel: str, curves: Mapping[str, AllanCurve], unit: str) -> None:
    lo, hi = math.inf, 0.0
    t_lo, t_hi = math.inf, 0.0
    first: tuple[AllanCurve, NoiseParameters] | None = None
    for k, (label, c) in enumerate(curves.items()):
        p = noise_parameters(c)
        first = first or (c, p)
        ok = c.adev > 0
        t, s, e = c.tau_s[ok], c.adev[ok], c.adev_err[ok]
        if t.size == 0:
            continue
        color = f"C{k}"
        ax.fill_between(t, np.maximum(s - e, s * 0.05), s + e, color=color, alpha=0.15, lw=0)
        ax.plot(t, s, color=color, lw=1.3, marker=".", ms=4, label=_legend_label(label, p, unit))
        if p.b is not None and p.b_tau_s is not None:
            ax.plot([p.b_tau_s], [p.b * BIAS_INSTABILITY_FACTOR], ls="none", marker="o",
                    mfc="none", mec=color, ms=8)  # fmt: skip
        lo, hi = min(lo, float(s.min())), max(hi, float(s.max()))
        t_lo, t_hi = min(t_lo, float(t[0])), max(t_hi, float(t[-1]))
    if first is not None and hi > 0:
        c, p = first
        ok = c.adev > 0
        t, s = c.tau_s[ok], c.adev[ok]
        tt = np.geomspace(t_lo, t_hi, 50)
        if p.n is not None:
            ax.plot(tt, p.n / np.sqrt(tt), **_REF_STYLE, label="slope −½ (N line)")
        else:
            ax.plot(tt, s[0] * np.sqrt(t[0] / tt), **_REF_STYLE, label="slope −½ (guide)")
        if p.k is not None:
            ax.plot(tt, p.k * np.sqrt(tt / 3.0), **_REF_STYLE, label="slope +½ (K line)")
        else:
            i = int(np.argmin(s))
            ax.plot(tt, s[i] * np.sqrt(tt / t[i]), **_REF_STYLE, label="slope +½ (guide)")
        ax.set_xlim(t_lo / 1.3, t_hi * 1.3)
        ax.set_ylim(lo / 2.0, hi * 2.0)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_title(channel, fontsize=10)
    ax.set_xlabel("averaging time τ [s]")
    ax.set_ylabel(f"Allan deviation [{unit}]")
    ax.grid(True, which="major", lw=0.5, alpha=0.6)
    ax.grid(True, which="minor", lw=0.3, alpha=0.3)
    ax.legend(fontsize=7, loc="best")


def allan_figure(
    curves: Mapping[str, Mapping[str, AllanCurve]],
    units: Mapping[str, str] | None = None,
    *,
    title: str | None = None,
    ncols: int = 3,
) -> Figure:
    """Log-log Allan deviation grid, one panel per channel, curves overlaid per label.

    Parameters
    ----------
    curves : mapping of str to mapping of str to AllanCurve
        Channel -> label (e.g. ``"raw"``, ``"compensated"``) -> curve, in the channel's
        unit; panels follow the channel order, colours the label order. The reference
        slopes are drawn for the first label of each panel.
    units : mapping of str to str, optional
        Channel -> unit of its samples (``"deg/h"``, ``"ug"``, ...); N is labelled in
        unit·√s, B in unit, K in unit/√s. Channels without one read "log units".
    title : str, optional
        Figure title.
    ncols : int
        Panels per row.

    Returns
    -------
    matplotlib.figure.Figure
        The figure, not yet saved; about 4.6 × 3.8 inch per panel.
    """
    if not curves:
        raise ConfigError("curves must name at least one channel")
    if ncols < 1:
        raise ConfigError(f"ncols must be >= 1, got {ncols!r}")
    for ch, by_label in curves.items():
        if not by_label:
            raise ConfigError(f"curves[{ch!r}] holds no curve")
    units = dict(units or {})
    n = len(curves)
    cols = min(ncols, n)
    rows = math.ceil(n / cols)
    fig = Figure(figsize=(4.6 * cols, 3.8 * rows), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False)
    for j, (ch, by_label) in enumerate(curves.items()):
        _panel(axes[j // cols, j % cols], str(ch), by_label, pretty_unit(units.get(ch)))
    for j in range(n, rows * cols):
        axes[j // cols, j % cols].set_axis_off()
    fig.suptitle(title or "Allan deviation (overlapping)", fontsize=12)
    return fig
