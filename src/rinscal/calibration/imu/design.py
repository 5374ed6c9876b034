"""The calibration's design: each segment's means, the regressors of each channel, and
whether the positions and rates observe every parameter asked for.

The regression of one channel ``j`` on the segment means (``s`` the reference input of
:func:`rinscal.turntable.reference_r`, a bar the mean over the segment's used samples)::

    ȳ_j = b_j + Σ_k K_jk · s̄_k + a_j · mean|s_j| + q_j · mean(s_j²)

Gyros use every segment (the static ones see the Earth rate) with regressors
``1, ω_x, ω_y, ω_z, |ω_j|, ω_j²``; accelerometers the static positions only, with
``1, f_x, f_y, f_z, f_j²`` (no asymmetry term). The model's parameters follow as
``sf_j = K_jj − 1`` and ``mis_jk = K_jk / K_jj`` (:mod:`rinscal.calibration.imu.estimate`).

Observability is checked twice: by the rules a turntable design must keep (a gyro's scale
factor and the misalignments towards its axis need a rate test about that axis; its
asymmetry rates of both signs; its quadratic term two rate magnitudes), which name what the
design lacks; then numerically (the singular values of the column-scaled regressors), which
catches any other degenerate set of positions and names the parameters in the null space.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rinscal import turntable
from rinscal.calibration.imu.segments import Segment, segment_references
from rinscal.errors import DesignError
from rinscal.sensormodel import AXES

__all__ = [
    "SegmentStats",
    "channel_parameters",
    "check_observable",
    "regressors",
    "segment_stats",
]

#: Relative singular value below which a column-scaled design is taken as rank deficient.
_RANK_TOL = 1e-7
#: A rate segment is "about axis j" when the table rate's component on j is at least this
#: fraction of the rate.
_ABOUT = 0.5
#: Blocks a segment is cut into to estimate the noise of its mean from its own samples.
_BLOCKS = 10


@dataclass(frozen=True)
class SegmentStats:
    """The means of one segment that the fit uses, in SI.

    Attributes
    ----------
    segment : Segment
    y : ndarray, shape (6,) [rad/s, m/s²]
        Mean output of gyro x..z, accel x..z.
    omega, abs_omega, sq_omega : ndarray, shape (3,) [rad/s, rad/s, (rad/s)²]
        Means of the reference rate, of its absolute value and of its square.
    f, sq_f : ndarray, shape (3,) [m/s², (m/s²)²]
        Means of the reference specific force and of its square.
    table_rate : ndarray, shape (3,) [rad/s]
        The table's own commanded rate in ``r`` (zero for a position).
    var : ndarray, shape (6,) [(rad/s)², (m/s²)²]
        Noise of one sample as the segment's block means show it: ``var(block means) ·
        samples per block`` (block means are immune to pulse quantisation, which a
        sample-to-sample scatter is not).
    temp : ndarray, shape (6,) [°C]
        Mean inner temperature of each channel.
    """

    segment: Segment
    y: NDArray[np.float64]
    omega: NDArray[np.float64]
    abs_omega: NDArray[np.float64]
    sq_omega: NDArray[np.float64]
    f: NDArray[np.float64]
    sq_f: NDArray[np.float64]
    table_rate: NDArray[np.float64]
    var: NDArray[np.float64]
    temp: NDArray[np.float64]


def _block_var(resid: NDArray[np.float64]) -> NDArray[np.float64]:
    """Per-sample noise variance from the scatter of block means, per column.

    The scatter is the normal-consistent median absolute deviation (1.4826·MAD) of the
    block means, not their variance: one block holding a vibration outlier (a real unit's,
    and the plant's) must not make a static position look as if it moved."""
    n = resid.shape[0]
    m = max(2, min(_BLOCKS, n // 5))
    size = n // m
    blocks = resid[: m * size].reshape(m, size, -1).mean(axis=1)
    if m < 5:
        return blocks.var(axis=0, ddof=1) * size
    mad = np.median(np.abs(blocks - np.median(blocks, axis=0)), axis=0) * 1.4826
    return mad**2 * size


def segment_stats(
    seg: Segment,
    time_s: NDArray[np.float64],
    table: NDArray[np.float64],
    y_si: NDArray[np.float64],
    temps: NDArray[np.float64],
    site: tuple[float, float, float],
) -> SegmentStats:
    """Means, reference inputs and noise of one segment.

    Parameters
    ----------
    seg : Segment
    time_s : ndarray, shape (n,) [s]
        The run's times.
    table : ndarray, shape (n, 4)
        The run's turntable columns.
    y_si : ndarray, shape (n, 6) [rad/s, m/s²]
        The run's outputs in SI.
    temps : ndarray, shape (n, 6) [°C]
        Inner temperature of each channel.
    site : (float, float, float)
        Latitude [rad], azimuth of the outer axis [rad], height [m].

    Returns
    -------
    SegmentStats
    """
    lat, heading, alt = site
    w, aw, sw, f = segment_references(seg, time_s, table, lat, heading, alt)
    y = y_si[seg.start : seg.stop]
    ref = np.concatenate([w, f], axis=1)
    var = _block_var(y - ref)
    if seg.kind == "rate":
        var[3:] = np.nan  # accelerometers are calibrated on positions only
        ro = seg.rate_dps if seg.axis == "outer" else 0.0
        ri = seg.rate_dps if seg.axis == "inner" else 0.0
        rate_r = turntable.table_rate_r(seg.inner_deg, ro, ri)
    else:
        rate_r = np.zeros(3)
    return SegmentStats(
        segment=seg,
        y=y.mean(axis=0),
        omega=w.mean(axis=0),
        abs_omega=aw.mean(axis=0),
        sq_omega=sw.mean(axis=0),
        f=f.mean(axis=0),
        sq_f=(f * f).mean(axis=0),
        table_rate=rate_r,
        var=var,
        temp=temps[seg.start : seg.stop].mean(axis=0),
    )


def channel_parameters(sensor: str, j: int, nonlinear: bool) -> list[str]:
    """Names of the regression coefficients of one channel, in column order.

    ``bias``, ``K0 K1 K2`` (the row of the linear matrix), then ``sf_asym`` (gyros) and
    ``sf_quad`` when ``nonlinear``; returned as parameter-like labels, e.g.
    ``gyro_bias_x, gyro_K_xx, gyro_K_xy, gyro_K_xz, gyro_sf_asym_x, gyro_sf_quad_x``.
    """
    ax = AXES[j]
    out = [f"{sensor}_bias_{ax}", *(f"{sensor}_K_{ax}{o}" for o in AXES)]
    if nonlinear:
        if sensor == "gyro":
            out.append(f"gyro_sf_asym_{ax}")
        out.append(f"{sensor}_sf_quad_{ax}")
    return out


def regressors(
    stats: list[SegmentStats], sensor: str, j: int, nonlinear: bool
) -> tuple[NDArray[np.float64], list[SegmentStats]]:
    """Design matrix of one channel and the segments (rows) it uses.

    Returns
    -------
    a : ndarray, shape (rows, p)
        Columns as :func:`channel_parameters`.
    rows : list of SegmentStats
    """
    rows = stats if sensor == "gyro" else [s for s in stats if s.segment.kind == "static"]
    cols: list[NDArray[np.float64]] = [np.ones(len(rows))]
    if sensor == "gyro":
        cols += [np.array([s.omega[k] for s in rows]) for k in range(3)]
        if nonlinear:
            cols.append(np.array([s.abs_omega[j] for s in rows]))
            cols.append(np.array([s.sq_omega[j] for s in rows]))
    else:
        cols += [np.array([s.f[k] for s in rows]) for k in range(3)]
        if nonlinear:
            cols.append(np.array([s.sq_f[j] for s in rows]))
    return np.stack(cols, axis=1), rows


def _label(name: str) -> str:
    """``gyro_K_xy`` -> ``gyro_mis_xy``, ``gyro_K_xx`` -> ``gyro_sf_x`` (names users know)."""
    sensor, kind, rest = name.split("_", 2)
    if kind != "K":
        return name
    return f"{sensor}_sf_{rest[0]}" if rest[0] == rest[1] else f"{sensor}_mis_{rest}"


def _rate_rules(stats: list[SegmentStats], nonlinear: bool) -> list[str]:
    """What the rate tests lack for each gyro axis, in words."""
    problems = []
    rates = [s.table_rate for s in stats if s.segment.kind == "rate"]
    for j, ax in enumerate(AXES):
        about = [r[j] for r in rates if abs(r[j]) >= _ABOUT * np.linalg.norm(r)]
        others = ", ".join(f"gyro_mis_{o}{ax}" for o in AXES if o != ax)
        if not about:
            problems.append(
                f"gyro_sf_{ax}, {others} need a rate test about {ax} (the design has none; "
                "the Earth rate alone is too weak)"
            )
            continue
        if not nonlinear:
            continue
        signs = {bool(v > 0) for v in about}
        mags = sorted({round(abs(float(v)), 9) for v in about})
        distinct = [m for k, m in enumerate(mags) if k == 0 or m > 1.05 * mags[k - 1]]
        if len(signs) < 2 or len(distinct) < 2:
            lacks = []
            if len(signs) < 2:
                lacks.append("rates of only one sign")
            if len(distinct) < 2:
                lacks.append("only one rate magnitude")
            problems.append(
                f"gyro_sf_asym_{ax} and gyro_sf_quad_{ax} need rate tests about {ax} at two or "
                f"more rates of both signs (the design has {' and '.join(lacks)})"
            )
    return problems


def _rank_problems(a: NDArray[np.float64], names: list[str]) -> list[str]:
    """Parameters in the (numerical) null space of a design, as one sentence or none."""
    if a.shape[0] < a.shape[1]:
        return [
            f"{', '.join(_label(n) for n in names)}: {a.shape[0]} segment(s) for "
            f"{a.shape[1]} unknowns"
        ]
    scale = np.max(np.abs(a), axis=0)
    scale[scale == 0] = 1.0
    _, sv, vt = np.linalg.svd(a / scale, full_matrices=False)
    null = vt[sv < _RANK_TOL * sv[0]]
    if null.size == 0:
        return []
    weight = (null**2).sum(axis=0)
    bad = [_label(n) for n, w in zip(names, weight, strict=True) if w > 1e-3]
    return [f"{', '.join(bad)} are not separable with these positions"]


def check_observable(stats: list[SegmentStats], nonlinear: bool, where: str) -> None:
    """Refuse a design that does not observe every parameter asked for.

    Parameters
    ----------
    stats : list of SegmentStats
        The segments of one run (or one repetition of a ramp).
    nonlinear : bool
        Whether the asymmetry and quadratic terms are estimated.
    where : str
        What the segments are (``run cal_+20C``), for the message.

    Raises
    ------
    DesignError
        Naming the parameters and what the design lacks.
    """
    n_static = sum(s.segment.kind == "static" for s in stats)
    problems = _rate_rules(stats, nonlinear)
    if n_static == 0:
        problems.append("accelerometer parameters need static positions (the design has none)")
    else:
        for j in range(3):
            names = channel_parameters("accel", j, nonlinear)
            a, _ = regressors(stats, "accel", j, nonlinear)
            for p in _rank_problems(a, names):
                problems.append(
                    f"{p} (accel_sf_{AXES[j]} and accel_sf_quad_{AXES[j]} need axis {AXES[j]} "
                    "up, down and horizontal; each misalignment a tilt towards its axis)"
                )
    if not problems:
        for j in range(3):
            a, _ = regressors(stats, "gyro", j, nonlinear)
            problems += _rank_problems(a, channel_parameters("gyro", j, nonlinear))
    if problems:
        hint = (
            " (or leave the nonlinear terms at zero: nonlinear=False, --linear)"
            if nonlinear and any("asym" in p or "quad" in p for p in problems)
            else ""
        )
        raise DesignError(
            f"{where}: the positions and rates do not observe every parameter: "
            + "; ".join(problems)
            + hint
        )
