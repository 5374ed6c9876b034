"""The figures of a study's report, and a check that no two tick labels of a figure overlap.

Every number drawn here was computed in :mod:`rinscal.experiments.study`; these functions
only place it. Each returns the matplotlib figure (so that :func:`label_overlaps` can check
it); :func:`rinscal.report.html.figure_to_png` renders it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from rinscal.experiments.paper.config import LABELS

__all__ = [
    "CELL_COLORS",
    "COLORS",
    "MAX_WIDTH_IN",
    "distribution_figure",
    "interval_limits",
    "label_overlaps",
    "map_figure",
    "paired_figure",
    "short_label",
]

#: Colours of the variants in every figure.
COLORS = {
    "none": "#6e7781",
    "poly-t": "#8250df",
    "sectional": "#cf222e",
    "regression": "#0969da",
    "regression-no-dT": "#54aeff",
    "neural": "#1a7f37",
    "true": "#000000",
}
#: Fill of a map cell: resolved better, resolved worse, unresolved, no interval.
CELL_COLORS = {
    "better": "#a6dba0",
    "worse": "#f4a582",
    "unresolved": "#e6e6e6",
    "not enough units": "#ffffff",
}


def short_label(v: str) -> str:
    """A variant's name for axes: ``method 2``, ``cubic in T``, ``none``, ``oracle``."""
    return {
        "none": "none",
        "poly-t": "cubic in T",
        "true": "oracle",
        "regression-no-dT": "method 2 w/o ΔT",
    }.get(v, LABELS.get(v, v).split(" (")[0])


def label_overlaps(fig: Any) -> list[tuple[str, str]]:
    """Pairs of tick labels of ``fig`` whose drawn extents overlap.

    The figure's canvas is drawn, then every visible, non-empty tick label of every axes
    (x and y) is compared with every other by its window extent
    (:meth:`matplotlib.text.Text.get_window_extent`, pixels); labels of different axes are
    compared too, so a panel's y labels running into its neighbour are caught.

    Returns
    -------
    list of (str, str)
        The texts of each overlapping pair (empty: nothing overlaps).
    """
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    boxes = []
    for ax in fig.get_axes():
        for t in [*ax.get_xticklabels(), *ax.get_yticklabels()]:
            if t.get_visible() and t.get_text().strip():
                boxes.append((t.get_text(), t.get_window_extent(renderer)))
    out = []
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            if boxes[i][1].overlaps(boxes[j][1]):
                out.append((boxes[i][0], boxes[j][0]))
    return out


def _pyplot() -> Any:
    # deferred: matplotlib loads in ~0.3 s, for figures only; Agg is chosen before pyplot
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


#: The widest a study figure is drawn [in]: at the PNG's 110 dpi it fits the report's
#: column (about 1 070 px) unscaled, so an 8-10 pt text reads at 12-15 px, not 7.
MAX_WIDTH_IN = 9.6


def _panels(plt: Any, n: int, height_in: float) -> tuple[Any, list[Any]]:
    """A figure of ``n`` panels, at most two a row, no wider than :data:`MAX_WIDTH_IN`;
    the axes of the unused cell of an odd last row are removed."""
    ncols = min(n, 2)
    nrows = -(-n // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(MAX_WIDTH_IN, height_in * nrows), squeeze=False)
    flat = list(axes.ravel())
    for ax in flat[n:]:
        ax.remove()
    return fig, flat[:n]


def interval_limits(
    lo: Sequence[float], hi: Sequence[float], d: Sequence[float]
) -> tuple[float, float]:
    """x limits [nmi] of the symlog axis (linear within ±0.1 nmi) that hold every interval
    ``[lo, hi]`` and estimate ``d`` (non-finite ones left out) and zero: each side 1.6 times
    the farthest value (a fifth of a decade), at least 0.1 nmi, so no marker or cap sits on
    the frame."""
    vals = np.asarray([*lo, *hi, *d, 0.0], dtype=float)
    vals = vals[np.isfinite(vals)]
    return (min(1.6 * float(vals.min()), -0.1), max(1.6 * float(vals.max()), 0.1))


def _log_label(v: float, _pos: int) -> str:
    """A log axis's tick as a plain number (0.3, 1, 2, not 3 × 10⁻¹), only at 1, 2, 3 and
    5 times a power of ten so that the labels do not crowd."""
    if not v > 0:
        return ""
    mantissa = v / 10.0 ** math.floor(math.log10(v) + 1e-9)
    return f"{v:g}" if round(mantissa, 6) in (1.0, 2.0, 3.0, 5.0) else ""


def distribution_figure(results: pd.DataFrame, plant: int) -> Any:
    """Maximum position error of every run per method and scenario (one plant)."""
    plt = _pyplot()
    df = results[results["plant"] == plant]
    scens = list(dict.fromkeys(df["scenario"]))
    variants = [v for v in COLORS if v in set(df["variant"])]
    fig, axes = _panels(plt, len(scens), 3.9)
    rng = np.random.default_rng(0)
    for ax, scen in zip(axes, scens, strict=True):
        g = df[df["scenario"] == scen]
        data = [g.loc[g["variant"] == v, "max_error_nmi"].to_numpy(float) for v in variants]
        ax.boxplot(data, showfliers=False, widths=0.6)
        for i, (v, y) in enumerate(zip(variants, data, strict=True)):
            x = i + 1 + rng.uniform(-0.18, 0.18, y.size)
            ax.plot(x, y, ".", color=COLORS[v], alpha=0.5, ms=4)
            ax.plot(i + 1, np.mean(y), "D", color="k", ms=4)
        ax.set_xticks(
            range(1, len(variants) + 1),
            [short_label(v) for v in variants],
            rotation=40,
            ha="right",
            fontsize=8,
        )
        ax.set_yscale("log")
        ax.yaxis.set_major_formatter(plt.FuncFormatter(_log_label))
        ax.yaxis.set_minor_formatter(plt.FuncFormatter(_log_label))
        ax.set_title(scen, fontsize=11)
        ax.set_ylabel("max horizontal position error [nmi]")
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle(
        f"{df['plant_label'].iloc[0]}: every run (dots), mean (◆), box = quartiles (log axis)",
        fontsize=10,
    )
    fig.tight_layout()
    return fig


def paired_figure(comp: pd.DataFrame, plant: int) -> Any:
    """Paired difference method − reference [nmi] with its interval, per scenario: each
    method against no compensation (circles) and against the cubic in T (squares); a
    marker is filled in colour only where the interval excludes zero."""
    plt = _pyplot()
    c = comp[(comp["plant"] == plant) & comp["reference"].isin(["none", "poly-t"])]
    scens = list(dict.fromkeys(c["scenario"]))
    methods = [v for v in COLORS if v in set(c["method"]) and v not in ("none", "true")]
    fig, axes = _panels(plt, len(scens), 1.2 + 0.42 * len(methods))
    xlim = interval_limits(c["delta ci low"], c["delta ci high"], c["delta"])
    for k, (ax, scen) in enumerate(zip(axes, scens, strict=True)):
        g = c[c["scenario"] == scen]
        for i, m in enumerate(methods):
            for ref, dy, marker in (("none", -0.15, "o"), ("poly-t", 0.15, "s")):
                r = g[(g["method"] == m) & (g["reference"] == ref)]
                if r.empty:
                    continue
                r = r.iloc[0]
                lo, hi, d = r["delta ci low"], r["delta ci high"], r["delta"]
                ok = math.isfinite(lo) and math.isfinite(hi)
                color = "#1a7f37" if ok and hi < 0 else "#cf222e" if ok and lo > 0 else "#6e7781"
                xerr = [[max(0.0, d - lo)], [max(0.0, hi - d)]] if ok else None
                ax.errorbar(
                    d,
                    i + dy,
                    xerr=xerr,
                    fmt=marker,
                    color=color,
                    mfc=color if ok and color != "#6e7781" else "white",
                    capsize=2,
                    ms=5,
                )
        ax.axvline(0, color="k", lw=0.8)
        ax.set_xscale("symlog", linthresh=0.1)
        ax.set_yticks(range(len(methods)))
        ax.set_yticklabels([short_label(m) for m in methods] if k % 2 == 0 else [], fontsize=9)
        ax.set_ylim(len(methods) - 0.5, -0.5)
        ax.set_xlim(*xlim)  # one scale for every panel, every interval inside it
        ax.set_title(scen, fontsize=11)
        ax.set_xlabel("method − reference [nmi] (symlog)", fontsize=9)
        ax.tick_params(axis="x", labelsize=8)
        ax.grid(axis="x", alpha=0.3)
    label = c["plant_label"].iloc[0] if not c.empty else ""
    fig.suptitle(
        f"{label}: paired difference of the max position error: ○ against no compensation, "
        "□ against the cubic in T; filled green/red where the 95 % interval excludes zero (method "
        "better/worse), open grey where it does not or there is none",
        fontsize=9,
        wrap=True,
    )
    fig.tight_layout()
    return fig


_MAP_COLS = (
    ("regression", "none", "m2 − none"),
    ("regression", "poly-t", "m2 − cubic"),
    ("neural", "none", "m3 − none"),
    ("neural", "poly-t", "m3 − cubic"),
)


def _plant_tick(r: pd.Series) -> str:
    return (
        f"Ṫ {r['accel_rate_ug_per_c_min']:.3g} µg/(°C/min)\n"
        f"ΔT {r['accel_grad_ug_per_c']:.3g} µg/°C\n"
        f"gyro Ṫ {r['gyro_rate_dph_per_c_min']:.2g} °/h/(°C/min)"
    )


def map_figure(cells: pd.DataFrame) -> Any:
    """The sensitivity map: a panel per thermal law (rows) and warm-up time (columns); in
    each, a row per plant variant (labelled by its equivalent sensitivities) and a column
    per method and reference; the cell shows method − reference [nmi] and its interval, and
    is coloured only where the interval excludes zero."""
    plt = _pyplot()
    laws = list(dict.fromkeys(cells["law"]))
    warm = sorted(dict.fromkeys(cells["warm-up [min]"]))
    n_rows = max(cells[cells["law"] == law]["plant"].nunique() for law in laws)
    fig, axes = plt.subplots(
        len(laws),
        len(warm),
        figsize=(2.2 + 3.3 * len(warm), 0.8 + len(laws) * (0.5 + 0.52 * n_rows)),
        squeeze=False,
    )
    for li, law in enumerate(laws):
        sub = cells[cells["law"] == law]
        plants = sub.drop_duplicates("plant").sort_values(
            ["accel_rate_ug_per_c_min", "gyro_rate_dph_per_c_min"]
        )
        for wi, w in enumerate(warm):
            ax = axes[li][wi]
            here = sub[sub["warm-up [min]"] == w]
            for i, (_, p) in enumerate(plants.iterrows()):
                for j, (m, ref, _) in enumerate(_MAP_COLS):
                    r = here[(here["plant"] == p["plant"]) & (here["method"] == m)]
                    r = r[r["reference"] == ref]
                    if r.empty:
                        continue
                    r = r.iloc[0]
                    ax.add_patch(
                        plt.Rectangle(
                            (j - 0.5, i - 0.5),
                            1,
                            1,
                            facecolor=CELL_COLORS[r["cell"]],
                            edgecolor="#d0d7de",
                        )
                    )
                    txt = f"{r['delta']:+.2f}"
                    if math.isfinite(r["delta ci low"]):
                        txt += f"\n[{r['delta ci low']:+.2f}, {r['delta ci high']:+.2f}]"
                    ax.text(j, i, txt, ha="center", va="center", fontsize=6.5)
            ax.set_xlim(-0.5, len(_MAP_COLS) - 0.5)
            ax.set_ylim(len(plants) - 0.5, -0.5)
            ax.set_xticks(range(len(_MAP_COLS)), [c[2] for c in _MAP_COLS], fontsize=7.5)
            ax.xaxis.tick_top()
            ax.set_yticks(range(len(plants)))
            ax.set_yticklabels(
                [_plant_tick(p) for _, p in plants.iterrows()] if wi == 0 else [], fontsize=6.5
            )
            ax.tick_params(length=0)
            ax.set_title(f"{law} law · alignment after {w:g} min warm-up", fontsize=9, pad=18)
    fig.suptitle(
        "method − reference, max position error [nmi], mean over units [95 % interval]: "
        "green = method better, red = worse (interval excludes zero); grey = not "
        "resolved; white = not enough runs (units) for an interval",
        fontsize=8,
        wrap=True,
    )
    fig.tight_layout()
    return fig
