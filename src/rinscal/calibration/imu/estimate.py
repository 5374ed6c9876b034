"""The estimate at one temperature: weighted least squares on segment means, motion checks,
and the model's parameters with their standard deviations.

Noise and standard deviations
-----------------------------
Each segment mean is weighted by the noise of one sample of its kind (positions, rate
segments), pooled over the segments from their own block means (:class:`SegmentStats`),
divided by its number of samples. The covariance of the coefficients is that of weighted
least squares, ``(AᵀWA)⁻¹``, scaled by ``max(1, χ²/ν)``, the residual's reduced chi-square:

- the within-segment scatter has hundreds of degrees of freedom (ten blocks in each of some
  thirty segments) and is the floor of the noise of a segment mean;
- the residual between segments has few (19 positions and 5 unknowns leave 14 for an
  accelerometer; its chi-square alone would put ±19 % of noise on every sd, and a 6-position
  design would have 1), but it sees what makes segments disagree beyond their own noise:
  the turntable's position and rate errors, drift, coloured noise. When it says more than
  the floor, it wins.

With white noise the sd is then honest to within a few percent (``max`` inflates it by the
mean excess of a chi-square over 1, ~7 % for 14 degrees of freedom); with turntable errors it
grows with them. ``chi2_nu`` of each channel is reported.

Motion
------
A position that was not static is refused, by two tests on each channel:

- its within-segment scatter (block means: noise and drift) is more than
  ``scatter_limit`` times the median of the run's positions (an F-ratio of 25 for the
  default 5, where chance gives at most ~4);
- its deleted residual (the fit without it, predicting it) is more than ``motion_sigma``
  times the positions' robust residual scale (1.4826 · median): a table turning slowly at a
  constant rate adds no scatter, but the gyros read its rate and the accelerometers a tilt.

The conversion to the model's parameters (:mod:`rinscal.sensormodel`): ``K = (I + K_sf)(I +
M)`` exactly, so ``sf_j = K_jj − 1`` and ``mis_jk = K_jk / K_jj``; the nonlinear regressors
use ``s_j`` where the model has ``u_j = s_j + Σ m_jk s_k``, which differs by a misalignment
(~1e-4) times a nonlinear term (~1e-5): ~1e-9 of the input, below any noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rinscal.calibration.imu.design import SegmentStats, regressors
from rinscal.calibration.regression import least_squares
from rinscal.errors import DesignError
from rinscal.schema import CHANNELS
from rinscal.sensormodel import AXES, parameter_spec

__all__ = ["BlockEstimate", "estimate_block"]


@dataclass(frozen=True)
class BlockEstimate:
    """Parameters estimated from one run (or one repetition of a ramp).

    Attributes
    ----------
    values, sds : dict of str to float
        Each parameter and its standard deviation, in its table unit
        (:func:`rinscal.sensormodel.parameter_spec`).
    temp : ndarray, shape (6,) [°C]
        Mean inner temperature of each channel over the segments used.
    chi2_nu : dict of str to float
        Reduced chi-square of each channel's fit against the within-segment noise.
    dof : dict of str to int
        Residual degrees of freedom of each channel's fit.
    """

    values: dict[str, float]
    sds: dict[str, float]
    temp: NDArray[np.float64]
    chi2_nu: dict[str, float]
    dof: dict[str, int]


def _pooled_var(rows: list[SegmentStats], c: int, skip: set[int]) -> dict[str, float]:
    """Per-sample noise variance of channel ``c``, pooled per segment kind."""
    out = {}
    for kind in ("static", "rate"):
        v = [s.var[c] for k, s in enumerate(rows) if s.segment.kind == kind and k not in skip]
        v = [x for x in v if np.isfinite(x)]
        out[kind] = float(np.mean(v)) if v else np.nan
    return out


def _scatter_outliers(
    stats: list[SegmentStats], scatter_limit: float
) -> list[tuple[SegmentStats, str, float]]:
    """Positions whose within-segment scatter is far beyond the others' (per channel)."""
    static = [s for s in stats if s.segment.kind == "static"]
    if len(static) < 3:
        return []
    out = []
    for c, ch in enumerate(CHANNELS):
        v = np.array([s.var[c] for s in static])
        med = float(np.median(v))
        if med <= 0:
            continue
        for s, ratio in zip(static, np.sqrt(v / med), strict=True):
            if ratio > scatter_limit:
                out.append((s, f"{ch} scatter {ratio:.1f}× the positions' median", ratio))
    return out


def _solve(
    a: NDArray[np.float64], y: NDArray[np.float64], sd: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Weighted least squares: coefficients, covariance (unit weights), weighted residuals,
    leverages."""
    aw, yw = a / sd[:, None], y / sd
    coef = least_squares(aw, yw)
    cov = np.linalg.pinv(aw.T @ aw)
    resid = yw - aw @ coef
    lev = np.einsum("ij,jk,ik->i", aw, cov, aw)
    return coef, cov, resid, lev


def _to_parameters(
    sensor: str, j: int, coef: NDArray[np.float64], cov: NDArray[np.float64], nonlinear: bool
) -> tuple[dict[str, float], dict[str, float]]:
    """Regression coefficients of one channel -> the model's parameters (table units)."""
    ax = AXES[j]
    kjj = coef[1 + j]
    names, grads, vals = [], [], []
    p = coef.size

    def add(name: str, value: float, grad: NDArray[np.float64]) -> None:
        to_si = parameter_spec(name).to_si
        names.append(name)
        vals.append(value / to_si)
        grads.append(grad / to_si)

    e = np.eye(p)
    add(f"{sensor}_bias_{ax}", coef[0], e[0])
    add(f"{sensor}_sf_{ax}", kjj - 1.0, e[1 + j])
    for k, other in enumerate(AXES):
        if k != j:
            g = e[1 + k] / kjj - e[1 + j] * coef[1 + k] / kjj**2
            add(f"{sensor}_mis_{ax}{other}", coef[1 + k] / kjj, g)
    if nonlinear:
        if sensor == "gyro":
            add(f"gyro_sf_asym_{ax}", coef[4], e[4])
        add(f"{sensor}_sf_quad_{ax}", coef[p - 1], e[p - 1])
    jac = np.array(grads)
    sd = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", jac, cov, jac), 0.0))
    return dict(zip(names, map(float, vals), strict=True)), dict(
        zip(names, map(float, sd), strict=True)
    )


def estimate_block(
    stats: list[SegmentStats],
    where: str,
    *,
    nonlinear: bool,
    motion_sigma: float,
    scatter_limit: float,
) -> BlockEstimate:
    """Estimate every parameter from the segments of one run.

    Parameters
    ----------
    stats : list of SegmentStats
        The run's segments (observability already checked,
        :func:`rinscal.calibration.imu.design.check_observable`).
    where : str
        What the segments are (``run cal_+20C``), for messages.
    nonlinear : bool
        Estimate the asymmetry and quadratic terms (else they are left at zero).
    motion_sigma : float
        A position whose deleted residual exceeds this many robust residual scales is
        refused as not static.
    scatter_limit : float
        A position whose within-segment scatter exceeds this many times the median of the
        positions' is refused as not static.

    Returns
    -------
    BlockEstimate

    Raises
    ------
    DesignError
        Naming the positions that were not static.
    """
    flagged = _scatter_outliers(stats, scatter_limit)
    skip = {id(s) for s, _, _ in flagged}
    values: dict[str, float] = {}
    sds: dict[str, float] = {}
    chi2: dict[str, float] = {}
    dof: dict[str, int] = {}
    for c, ch in enumerate(CHANNELS):
        sensor, j = ("gyro", c) if c < 3 else ("accel", c - 3)
        a, rows = regressors(stats, sensor, j, nonlinear)
        y = np.array([s.y[c] for s in rows])
        pooled = _pooled_var(rows, c, {k for k, s in enumerate(rows) if id(s) in skip})
        floor = (1e-10 * float(np.max(np.abs(y))) + 1e-300) ** 2
        var1 = np.array([max(pooled[s.segment.kind], floor) for s in rows])
        sd = np.sqrt(var1 / np.array([s.segment.n for s in rows]))
        coef, cov, resid, lev = _solve(a, y, sd)
        nu = a.shape[0] - a.shape[1]
        c2 = float(resid @ resid / nu) if nu > 0 else float("nan")
        static = np.array([s.segment.kind == "static" for s in rows])
        if nu >= 2 and static.sum() >= 3:
            ok = lev < 1.0 - 1e-6
            t = np.where(ok, resid / np.sqrt(np.where(ok, 1.0 - lev, 1.0)), 0.0)
            scale = max(1.0, 1.4826 * float(np.median(np.abs(t[static & ok]))))
            for k in np.flatnonzero(static & ok & (np.abs(t) > motion_sigma * scale)):
                flagged.append(
                    (
                        rows[k],
                        f"{ch} residual {abs(t[k]) / scale:.0f}× the positions' robust scale",
                        abs(t[k]) / scale,
                    )
                )
        inflate = max(1.0, c2) if nu > 0 else 1.0
        v, s_ = _to_parameters(sensor, j, coef, cov * inflate, nonlinear)
        values.update(v)
        sds.update(s_)
        chi2[ch], dof[ch] = c2, nu
    if flagged:
        worst: dict[int, tuple[SegmentStats, str, float]] = {}
        for s, why, score in flagged:
            if id(s) not in worst or score > worst[id(s)][2]:
                worst[id(s)] = (s, why, score)
        items = sorted(worst.values(), key=lambda x: x[0].segment.start)
        text = "; ".join(f"{s.segment.describe()}: {why}" for s, why, _ in items[:6])
        more = f" (and {len(items) - 6} more)" if len(items) > 6 else ""
        raise DesignError(
            f"{where}: motion detected, {len(items)} position(s) not static: {text}{more}. "
            "Check the turntable's log or drop the position."
        )
    weights = np.array([s.segment.n for s in stats], dtype=float)
    temp = (np.array([s.temp for s in stats]) * weights[:, None]).sum(axis=0) / weights.sum()
    return BlockEstimate(values, sds, temp, chi2, dof)
