"""The one selection rule: the simplest candidate whose held-out RMS is near the least.

Every place that chooses a model by held-out error uses this rule and gives its
``tolerance`` the same meaning:

    **tolerance** [dimensionless]: the relative excess of a candidate's held-out RMS over the
    least held-out RMS of the candidates. Candidate ``i`` is within it when
    ``rms_i ≤ (1 + tolerance) · min_j rms_j``; among those, the simplest is chosen.

Where it is used, with its default (:data:`DEFAULT_TOLERANCES`), and why the defaults differ:

``fit --method auto`` and ``select --method auto`` (:data:`AUTO_TOLERANCE` = 0)
    The held-out RMS of 60 s means of the residual, over several folds. A one-sided paired
    t-test on the folds' log error ratios already keeps every candidate that noise cannot tell
    from the best (:func:`rinscal.calibration.selection.auto.choose`); the tolerance only
    widens that, so by default it adds nothing.
``select --method regression`` / ``neural`` (:data:`SETTINGS_TOLERANCE` = 0.02)
    Leave-one-run-out RMS per sample of one setting swept (orders ``p = q = s = k`` or hidden
    neurons) with no test: a larger setting must gain more than 2 % (this package's
    convention, not a statistical test, and not the paper's).
``calibrate-imu`` laws (:data:`LAW_TOLERANCE` = 0.2)
    Leave-one-temperature-out RMS of a parameter's law, in units of the estimates' sd, over
    a handful of temperatures: with five, a higher degree often scores a little better by
    chance alone (:mod:`rinscal.calibration.imu.laws`).

Before this module, ``fit --tolerance`` was a relative excess of the held-out *mean square*
error; a value ``m`` given then is the RMS tolerance ``√(1 + m) − 1`` now
(:func:`from_mean_square`). Its default, 0, is 0 in both, so default choices are unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "AUTO_TOLERANCE",
    "DEFAULT_TOLERANCES",
    "LAW_TOLERANCE",
    "SETTINGS_TOLERANCE",
    "from_mean_square",
    "simplest_within",
    "within_tolerance",
]

#: ``fit``/``select --method auto``: on top of the paired test, which already allows for noise.
AUTO_TOLERANCE = 0.0
#: ``select --method regression`` / ``neural``: a setting swept without a test.
SETTINGS_TOLERANCE = 0.02
#: ``calibrate-imu`` laws: a handful of temperatures, leave-one-out in units of the sd.
LAW_TOLERANCE = 0.2
#: The default of each situation, by the name the user meets it under.
DEFAULT_TOLERANCES: dict[str, float] = {
    "auto": AUTO_TOLERANCE,
    "regression": SETTINGS_TOLERANCE,
    "neural": SETTINGS_TOLERANCE,
    "imu-law": LAW_TOLERANCE,
}


def within_tolerance(rms: ArrayLike, tolerance: float) -> NDArray[np.bool_]:
    """Which candidates' held-out RMS is within ``tolerance`` of the least.

    Parameters
    ----------
    rms : array_like, shape (n,) [any unit, the same for all]
        Held-out RMS of each candidate; NaN or ±inf where a candidate could not be scored
        (never within).
    tolerance : float [dimensionless]
        Relative excess over the least RMS: ``rms_i ≤ (1 + tolerance) · min rms``.

    Returns
    -------
    ndarray of bool, shape (n,)
        All False when no candidate has a finite RMS.
    """
    r = np.asarray(rms, dtype=np.float64)
    ok = np.isfinite(r)
    if not ok.any():
        return np.zeros(r.shape, dtype=bool)
    least = float(np.min(r[ok]))
    return ok & (r <= least * (1.0 + tolerance))


def simplest_within(
    rms: ArrayLike, tolerance: float, complexity: Sequence[float] | None = None
) -> int:
    """Index of the simplest candidate whose held-out RMS is within ``tolerance`` of the least.

    Parameters
    ----------
    rms : array_like, shape (n,) [any unit, the same for all]
        Held-out RMS of each candidate (NaN: not scored, never chosen).
    tolerance : float [dimensionless]
        As for :func:`within_tolerance`.
    complexity : sequence of float, optional
        Complexity of each candidate (e.g. its polynomial order or neuron count); the least
        wins, the first listed among equals. Default: the order given (simplest first).

    Returns
    -------
    int

    Raises
    ------
    ValueError
        When no candidate has a finite RMS.
    """
    near = np.flatnonzero(within_tolerance(rms, tolerance))
    if not near.size:
        raise ValueError("no candidate has a finite held-out RMS")
    if complexity is None:
        return int(near[0])
    return int(min(near, key=lambda i: (complexity[i], i)))


def from_mean_square(tolerance: float) -> float:
    """The RMS tolerance equal to a relative tolerance ``m`` on the mean square: ``√(1+m) − 1``.

    ``ms_i ≤ (1 + m) · ms_best`` ⇔ ``rms_i ≤ √(1 + m) · rms_best``; both dimensionless.
    """
    return math.sqrt(1.0 + tolerance) - 1.0
