"""Each parameter as a function of temperature, its degree chosen on held-out temperatures.

At each set point (or each repetition of the sequence along a ramp) a parameter has an
estimate ``v_i ± sd_i`` at the mean inner temperature ``T_i`` of its own channel. The law is a
polynomial in ``T − t0_c`` of degree ``0 .. min(max_degree, n − 3)`` (``0 .. 1`` for three or
four temperatures, ``0`` for two), plus, on a ramp, a term linear in the temperature rate
``Ṫ`` [°C/min] where the repetitions' rates differ. Each candidate is scored by
leave-one-temperature-out prediction: fitted (weighted by ``1/sd²``) on the other
temperatures, it predicts the one left out; the score is the RMS of the prediction errors in
units of that estimate's sd (about 1 for a law that predicts within the noise).

Why not up to ``n − 2``: a law of degree ``n − 2`` fitted on ``n − 1`` points passes through
them, and its ``n`` held-out errors are all multiples of one number (the ``(n−1)``-th finite
difference of the estimates), which is near zero by chance about one time in ten: a cubic
through five noisy temperatures would then score best with no evidence for it. From three
temperatures a straight line is still allowed (its errors are one number too, but the
alternative, a constant, is the only other choice). The candidate
of least score wins, or the simplest candidate whose score is within ``tolerance`` (20 %)
of it: with five temperatures a higher degree often scores a little better by chance alone
(the rule and its defaults: :mod:`rinscal.calibration.selection.rule`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from rinscal.calibration.regression import least_squares
from rinscal.calibration.selection.rule import LAW_TOLERANCE, simplest_within

__all__ = ["Law", "fit_law"]

#: Repetitions whose temperature rates spread less than this have no rate term [°C/min].
_MIN_RATE_SPREAD = 0.01


@dataclass(frozen=True)
class Law:
    """The chosen law of one parameter.

    Attributes
    ----------
    degree : int
        Degree of the polynomial in temperature.
    rate_degree : int
        0, or 1 for a term linear in the temperature rate (ramp only).
    t_coefs : tuple of float [unit/°C^k]
        About ``t0_c``, constant first.
    rate_coefs : tuple of float [unit/(°C/min)]
        Empty, or the rate coefficient.
    heldout_score : float
        Held-out RMS error of the chosen law in units of the estimates' sd (NaN when there is
        one temperature).
    scores : dict of str to float
        Score of every candidate, e.g. ``{"T1": 0.9, "T1+rate": 1.1}``.
    """

    degree: int
    rate_degree: int
    t_coefs: tuple[float, ...]
    rate_coefs: tuple[float, ...]
    heldout_score: float
    scores: dict[str, float]


def _top_degree(n: int) -> int:
    """Highest degree worth scoring with ``n`` temperatures: ``n − 3`` (at least 1 from 3)."""
    return 0 if n < 3 else max(1, n - 3)


def _design(x: NDArray[np.float64], r: NDArray[np.float64] | None, d: int) -> NDArray[np.float64]:
    cols = [x**k for k in range(d + 1)]
    if r is not None:
        cols.append(r)
    return np.stack(cols, axis=1)


def _wls(a: NDArray[np.float64], v: NDArray[np.float64], sd: NDArray[np.float64]) -> NDArray:
    return least_squares(a, v, sd)


def fit_law(
    temp_c: NDArray[np.float64],
    values: NDArray[np.float64],
    sds: NDArray[np.float64],
    t0_c: float,
    max_degree: int = 3,
    tdot_c_per_min: NDArray[np.float64] | None = None,
    tolerance: float = LAW_TOLERANCE,
) -> Law:
    """Choose and fit the law of one parameter.

    Parameters
    ----------
    temp_c : ndarray, shape (n,) [°C]
        Mean inner temperature of the parameter's channel at each estimate.
    values, sds : ndarray, shape (n,) [unit]
        Estimates and their standard deviations.
    t0_c : float [°C]
        Centre of the polynomial.
    max_degree : int
        Highest degree tried (capped at ``n − 3``, at least 1 from three temperatures).
    tdot_c_per_min : ndarray, shape (n,), optional [°C/min]
        Temperature rate of each estimate (ramp); a rate term is tried where it varies.
    tolerance : float [dimensionless]
        A simpler candidate whose score (a held-out RMS) is within this relative excess of
        the least wins (:func:`rinscal.calibration.selection.rule.simplest_within`).

    Returns
    -------
    Law
    """
    x = np.asarray(temp_c, dtype=float) - t0_c
    v = np.asarray(values, dtype=float)
    sd = np.asarray(sds, dtype=float)
    n = x.size
    tiny = 1e-12 * float(np.max(np.abs(v))) + 1e-300
    sd = np.where(sd > tiny, sd, tiny)
    if n == 1:
        return Law(0, 0, (float(v[0]),), (), float("nan"), {})
    rates: list[NDArray[np.float64] | None] = [None]
    if tdot_c_per_min is not None:
        r = np.asarray(tdot_c_per_min, dtype=float)
        if np.ptp(r) >= _MIN_RATE_SPREAD:
            rates.append(r)
    cands: list[tuple[float, int, int]] = []
    scores: dict[str, float] = {}
    for ri, r in enumerate(rates):
        for d in range(0, min(max_degree, _top_degree(n) - ri) + 1):
            err = np.empty(n)
            for i in range(n):
                keep = np.arange(n) != i
                a = _design(x, r, d)
                coef = _wls(a[keep], v[keep], sd[keep])
                err[i] = (v[i] - a[i] @ coef) / sd[i]
            score = float(np.sqrt(np.mean(err**2)))
            scores[f"T{d}" + ("+rate" if ri else "")] = score
            cands.append((score, d, ri))
    if not cands:  # n == 2 with a rate term asked for: only the constant is possible
        return Law(0, 0, (float(np.average(v, weights=sd**-2)),), (), float("nan"), scores)
    # the simplest candidate within the tolerance of the least score (candidates are in
    # order of complexity): five held-out points favour a wiggly law by chance alone
    score, d, ri = cands[simplest_within([c[0] for c in cands], tolerance)]
    coef = _wls(_design(x, rates[ri], d), v, sd)
    t_coefs = tuple(float(c) for c in coef[: d + 1])
    rate_coefs = (float(coef[d + 1]),) if ri else ()
    return Law(d, ri, t_coefs, rate_coefs, score, scores)
