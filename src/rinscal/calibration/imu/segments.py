"""Segments of a multi-position calibration run, read from the turntable's commanded columns.

A run's rows are split where the commanded state changes (see the log contract in
:mod:`rinscal.calibration.imu`):

- a **static position**: consecutive rows with both axis rates 0 and constant angles;
- a **rate segment**: consecutive rows with one constant nonzero axis rate (the other axis at
  a constant angle); only the samples that span a whole number of revolutions of the turning
  axis are kept, so that the Earth rate and gravity components perpendicular to the rotation
  axis average to zero;
- everything else is a **transition** (the table slews, accelerates or decelerates: commanded
  values changing row to row, both axes turning, or a constant-rate slew shorter than one
  revolution) and is not used.

After each change the unit is given ``settle_s`` seconds to settle: the samples whose
interval ends less than ``settle_s`` after the first sample of the segment are dropped.

The commanded angles are those at the END of each sample interval (at ``time_s``); a
sample's output is the mean over its interval, so a rate segment's reference is averaged
over the interval too (:func:`segment_references`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rinscal import turntable

__all__ = [
    "TABLE_COLUMNS",
    "Segment",
    "Split",
    "find_segments",
    "segment_references",
]

#: The turntable's commanded columns of a multi-position log: angles [deg] at the end of the
#: sample interval, rates [deg/s] during it.
TABLE_COLUMNS = (
    "table_outer_deg",
    "table_inner_deg",
    "table_outer_rate_dps",
    "table_inner_rate_dps",
)

#: Angles that differ by less than this are the same commanded angle [deg].
_ANGLE_TOL = 1e-7
#: Sub-intervals of a sample over which a rate segment's reference is averaged.
_SUBSTEPS = 8


@dataclass(frozen=True)
class Segment:
    """One static position or rate segment of a run: the samples the fit uses.

    Attributes
    ----------
    run : str
        Run name.
    kind : {"static", "rate"}
    number : int
        1-based index among the run's segments of the same kind, in time order
        ("position 7", "rate segment 3").
    start, stop : int
        Row positions of the used samples within the run's rows (``stop`` exclusive).
    outer_deg, inner_deg : float [deg]
        The position (static), or the angles at the end of the first used sample (rate).
    axis : {"outer", "inner"} or None
        Turning axis of a rate segment.
    rate_dps : float [deg/s]
        Commanded rate of the turning axis (0 for a position).
    turns : int
        Whole revolutions the used samples span (0 for a position).
    t_start_s, t_end_s : float [s]
        ``time_s`` of the first and last used sample.
    """

    run: str
    kind: str
    number: int
    start: int
    stop: int
    outer_deg: float
    inner_deg: float
    axis: str | None
    rate_dps: float
    turns: int
    t_start_s: float
    t_end_s: float

    @property
    def n(self) -> int:
        """Used samples."""
        return self.stop - self.start

    @property
    def signature(self) -> tuple[object, ...]:
        """What identifies the segment in a sequence (runs of one design share them)."""
        if self.kind == "static":
            return ("static", round(self.outer_deg, 4), round(self.inner_deg, 4))
        other = self.inner_deg if self.axis == "outer" else self.outer_deg
        return ("rate", self.axis, round(self.rate_dps, 6), round(other % 360.0, 4))

    def describe(self) -> str:
        """E.g. ``position 7 (outer 90°, inner 180°, 812.0-872.0 s)``."""
        span = f"{self.t_start_s:.1f}-{self.t_end_s:.1f} s"
        if self.kind == "static":
            return (
                f"position {self.number} (outer {self.outer_deg:g}°, inner {self.inner_deg:g}°, "
                f"{span})"
            )
        other = (
            f"inner at {self.inner_deg % 360:g}°"
            if self.axis == "outer"
            else f"outer at {self.outer_deg % 360:g}°"
        )
        rate = f"{self.axis} axis at {self.rate_dps:+g} °/s"
        return f"rate segment {self.number} ({rate}, {other}, {span})"


@dataclass(frozen=True)
class Split:
    """A run cut into segments.

    Attributes
    ----------
    segments : tuple of Segment
        In time order.
    slews : int
        Constant-rate groups shorter than one revolution after the settle time (slews
        between positions, not rate tests).
    short : int
        Static groups with fewer than ``min_samples`` samples after the settle time.
    short_longest_s : float [s]
        Duration (samples × interval) of the longest of them; 0 when none.
    short_settle_max_s : float or None [s]
        The longest settle time that would have kept ``min_samples`` samples of it (None:
        it has fewer samples than that).
    """

    segments: tuple[Segment, ...]
    slews: int
    short: int
    short_longest_s: float = 0.0
    short_settle_max_s: float | None = None


def _groups(o: NDArray, i: NDArray, ro: NDArray, ri: NDArray) -> list[tuple[int, int]]:
    """Row ranges of constant commanded state (angles of the non-turning axes, rates)."""
    n = o.shape[0]
    if n == 0:
        return []
    static = (ro == 0) & (ri == 0)
    change = np.zeros(n, dtype=bool)
    change[0] = True
    change[1:] |= (ro[1:] != ro[:-1]) | (ri[1:] != ri[:-1])
    # an angle that should not change did: for a position both, for a rate the other axis
    d_o = np.abs(np.diff(o)) > _ANGLE_TOL
    d_i = np.abs(np.diff(i)) > _ANGLE_TOL
    change[1:] |= (d_o & (ro[1:] == 0)) | (d_i & (ri[1:] == 0))
    change[1:] |= static[1:] & (d_o | d_i)
    starts = np.flatnonzero(change)
    stops = np.append(starts[1:], n)
    return list(zip(starts.tolist(), stops.tolist(), strict=True))


def find_segments(
    run: str,
    time_s: NDArray[np.float64],
    table: NDArray[np.float64],
    *,
    settle_s: float,
    min_samples: int = 10,
) -> Split:
    """Cut one run into static positions and whole-revolution rate segments.

    Parameters
    ----------
    run : str
        Run name (for the segments' descriptions).
    time_s : ndarray, shape (n,) [s]
        Sample times, increasing.
    table : ndarray, shape (n, 4) [deg, deg, deg/s, deg/s]
        The columns :data:`TABLE_COLUMNS`.
    settle_s : float [s]
        Time dropped after each change of the commanded state.
    min_samples : int
        Fewest samples a position keeps after the settle time (a shorter stop is a
        transition).

    Returns
    -------
    Split
    """
    o, i, ro, ri = (np.asarray(table[:, k], dtype=float) for k in range(4))
    t = np.asarray(time_s, dtype=float)
    dt_all = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    segments: list[Segment] = []
    counts = {"static": 0, "rate": 0}
    slews = short = 0
    longest = (0, 0)  # the longest short stop (g0, g1)
    for g0, g1 in _groups(o, i, ro, ri):
        if ro[g0] != 0 and ri[g0] != 0:
            continue  # both axes turn: a transition
        keep = np.flatnonzero(t[g0:g1] - t[g0] >= settle_s - 1e-9)
        if keep.size < min_samples:
            if ro[g0] == 0 and ri[g0] == 0 and g1 - g0 >= 2:
                short += 1
                longest = max(longest, (g0, g1), key=lambda g: g[1] - g[0])
            continue
        k0, k_end = g0 + int(keep[0]), g1 - 1
        if ro[g0] == 0 and ri[g0] == 0:
            counts["static"] += 1
            segments.append(
                Segment(
                    run,
                    "static",
                    counts["static"],
                    k0,
                    g1,
                    float(o[k0]),
                    float(i[k0]),
                    None,
                    0.0,
                    0,
                    float(t[k0]),
                    float(t[k_end]),
                )
            )
            continue
        axis = "outer" if ro[g0] != 0 else "inner"
        rate = float(ro[g0] if axis == "outer" else ri[g0])
        theta = o if axis == "outer" else i
        dt = float(np.median(np.diff(t[g0:g1]))) if g1 - g0 > 1 else dt_all
        theta0 = theta[k0] - rate * dt  # start of the first used sample's interval
        swept = np.abs(theta[k0:g1] - theta0)
        turns = int(np.floor(swept[-1] / 360.0 + 1e-6))
        if turns < 1:
            slews += 1
            continue
        k1 = k0 + int(np.argmin(np.abs(swept - 360.0 * turns)))
        counts["rate"] += 1
        segments.append(
            Segment(
                run,
                "rate",
                counts["rate"],
                k0,
                k1 + 1,
                float(o[k0]),
                float(i[k0]),
                axis,
                rate,
                turns,
                float(t[k0]),
                float(t[k1]),
            )
        )
    g0, g1 = longest
    settle_max = float(t[g1 - min_samples] - t[g0]) if g1 - g0 >= min_samples > 0 else None
    return Split(tuple(segments), slews, short, (g1 - g0) * dt_all, settle_max)


def segment_references(
    seg: Segment,
    time_s: NDArray[np.float64],
    table: NDArray[np.float64],
    lat: float,
    heading: float,
    alt: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """What an ideal IMU felt in each used sample of a segment, averaged over the interval.

    Parameters
    ----------
    seg : Segment
    time_s : ndarray, shape (n,) [s]
        The run's times.
    table : ndarray, shape (n, 4)
        The run's :data:`TABLE_COLUMNS`.
    lat, heading : float [rad]
        Site latitude and azimuth of the outer axis.
    alt : float [m]
        Height.

    Returns
    -------
    omega : ndarray, shape (seg.n, 3) [rad/s]
        Interval mean of the angular rate of ``r`` (Earth rate and the table's rate).
    abs_omega, sq_omega : ndarray, shape (seg.n, 3) [rad/s, (rad/s)²]
        Interval means of ``|ω_j|`` and ``ω_j²`` (the nonlinear regressors).
    f : ndarray, shape (seg.n, 3) [m/s²]
        Interval mean of the specific force.
    """
    rows = slice(seg.start, seg.stop)
    o, i = table[rows, 0], table[rows, 1]
    if seg.kind == "static":
        w, f = turntable.reference_r(o[0], i[0], lat, heading, alt)
        n = seg.n
        w_n = np.broadcast_to(w, (n, 3))
        return w_n, np.abs(w_n), w_n * w_n, np.broadcast_to(f, (n, 3))
    dt = np.diff(time_s[max(seg.start - 1, 0) : seg.stop])
    if seg.start == 0:  # the first sample of the file: its interval is the typical one
        dt = np.concatenate([[np.median(dt) if dt.size else 0.0], dt])
    # angles of the turning axis at the middle of S sub-intervals of each sample interval
    frac = (np.arange(_SUBSTEPS) + 0.5) / _SUBSTEPS - 1.0  # -1 + (m + 1/2)/S
    back = seg.rate_dps * dt[:, None] * frac[None, :]
    ro = seg.rate_dps if seg.axis == "outer" else 0.0
    ri = seg.rate_dps if seg.axis == "inner" else 0.0
    oo = (o[:, None] + (back if seg.axis == "outer" else 0.0)) * np.ones_like(back)
    ii = (i[:, None] + (back if seg.axis == "inner" else 0.0)) * np.ones_like(back)
    w, f = turntable.reference_r(oo.ravel(), ii.ravel(), lat, heading, alt, ro, ri)
    w = w.reshape(seg.n, _SUBSTEPS, 3)
    f = f.reshape(seg.n, _SUBSTEPS, 3)
    return w.mean(axis=1), np.abs(w).mean(axis=1), (w * w).mean(axis=1), f.mean(axis=1)
