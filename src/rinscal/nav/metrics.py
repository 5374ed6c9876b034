"""Navigation error metrics a navigation engineer reads: drift rate, CEP, the gyrocompass
heading error a bias rate implies, and the bias change within one modulation period.

Definitions (each function states its own):

drift rate
    The least-squares slope of the horizontal radial error against time over free
    navigation, intercept free [m/s] (``nmi/h`` at the edges). It is what an error budget
    calls "x nmi/h"; beside the maximum it says whether a run's error grows steadily or
    spikes and falls back (a Schuler-bounded or cancelling error has a small slope and a
    large maximum).
CEP
    The circular error probable of a *group of runs*: the radius of the circle about the
    true position that holds half of them, i.e. the median of their radial errors at one
    time (here the end of each run). It is a property of a distribution over runs, not of
    one run: the median radial error of one run over its own duration is not a CEP (its
    samples are one correlated path, and it mixes early and late times).
gyrocompass heading error
    The textbook result for a fixed (non-rotating) IMU aligned at rest by gyrocompassing:
    levelling holds the horizontal velocity at zero, so the tilt takes up the levelled
    accelerometer bias, ``φ_E = −∇_N/g``, ``φ_N = ∇_E/g``; a bias that changes makes the
    tilt change, ``φ̇_E = −∇̇_N/g``, which the gyrocompass cannot tell from a horizontal
    angular rate; it balances ``φ̇_E = Ω sin L φ_N − Ω cos L φ_U − ε_E`` at zero and so
    hands over ``φ_U = (−ε_E + ∇̇_N/g) / (Ω cos L) + tan L ∇_E/g``. In this package's
    convention (ENU, ``C̃_nr = (I − [φ×]) C_nr``) the heading error INS minus truth,
    clockwise from north, equals ``φ_U`` (checked in ``tests/nav/test_metrics.py`` against
    the alignment filter of :mod:`rinscal.nav.align`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.ndimage import maximum_filter1d, minimum_filter1d

from rinscal import earth
from rinscal.errors import ConfigError

__all__ = [
    "cep50",
    "drift_rate",
    "gyrocompass_heading_error",
    "max_change_within",
    "slope",
]


def slope(t: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
    """Least-squares slope of ``y`` against ``t``, intercept free, per column.

    Parameters
    ----------
    t : array_like, shape (n,) [s]
    y : array_like, shape (n,) or (n, m) [any unit]

    Returns
    -------
    ndarray, shape () or (m,) [unit of y per s]
        NaN where fewer than two distinct times are given.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.size < 2 or np.ptp(t) == 0:
        return np.full(y.shape[1:], np.nan)
    tc = t - t.mean()
    yc = y - y.mean(axis=0)
    return np.tensordot(tc, yc, axes=(0, 0)) / float(tc @ tc)


def drift_rate(time_s: ArrayLike, radial_m: ArrayLike) -> float:
    """Drift rate of a run: the least-squares slope of the radial error against time.

    Parameters
    ----------
    time_s : array_like, shape (n,) [s]
        Times of free navigation.
    radial_m : array_like, shape (n,) [m]
        Horizontal radial position error at those times.

    Returns
    -------
    float [m/s]
        The slope (intercept free); NaN for fewer than two samples.
    """
    return float(slope(time_s, radial_m))


def cep50(radial_m: ArrayLike) -> float:
    """Circular error probable of a group of runs: the median of their radial errors.

    Parameters
    ----------
    radial_m : array_like, shape (k,) [m or nmi]
        One radial error per run, all taken at the same time of each run (e.g. the end).

    Returns
    -------
    float [unit of the input]
        The radius of the circle holding half of the runs; NaN for an empty group.
    """
    r = np.asarray(radial_m, dtype=float)
    r = r[np.isfinite(r)]
    return float(np.median(r)) if r.size else math.nan


def gyrocompass_heading_error(
    lat: float,
    accel_rate_n: float = 0.0,
    gyro_e: float = 0.0,
    accel_e: float = 0.0,
    g: float | None = None,
) -> float:
    """Heading error a fixed IMU's gyrocompass alignment hands over (see the module notes).

    Parameters
    ----------
    lat : float [rad]
        Latitude.
    accel_rate_n : float [m/s³]
        Rate of change of the levelled north accelerometer bias over the alignment, ∇̇_N.
    gyro_e : float [rad/s]
        East gyro bias, ε_E.
    accel_e : float [m/s²]
        East accelerometer bias, ∇_E (its tan L coupling).
    g : float, optional [m/s²]
        Gravity; default :func:`rinscal.earth.gravity` at ``lat``.

    Returns
    -------
    float [rad]
        ``(−ε_E + ∇̇_N/g) / (Ω cos L) + tan L ∇_E/g``: heading INS minus truth, clockwise
        from north.
    """
    if not math.isfinite(lat) or abs(lat) >= math.pi / 2:
        raise ConfigError(f"gyrocompass: latitude must be inside (−90°, 90°), got {lat} rad")
    g = float(earth.gravity(lat, 0.0)) if g is None else float(g)
    om_n = earth.RATE * math.cos(lat)
    return (-gyro_e + accel_rate_n / g) / om_n + math.tan(lat) * accel_e / g


def max_change_within(t: ArrayLike, y: ArrayLike, window_s: float) -> NDArray[np.float64]:
    """Largest peak-to-peak change of ``y`` within any window of ``window_s`` [s].

    Rotation modulation assumes a bias constant over one modulation period; this is how far
    from constant it is.

    Parameters
    ----------
    t : array_like, shape (n,) [s]
        Uniformly spaced times.
    y : array_like, shape (n,) or (n, m) [any unit]
    window_s : float [s]
        Window length (e.g. the rotation schedule's period).

    Returns
    -------
    ndarray, shape () or (m,) [unit of y]
        ``max over windows (max − min)``, per column.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if not (math.isfinite(window_s) and window_s > 0):
        raise ConfigError(f"max_change_within: window_s must be > 0, got {window_s}")
    if t.size < 2:
        return np.zeros(y.shape[1:])
    dt = float(np.median(np.diff(t)))
    size = max(1, min(t.size, round(window_s / dt) + 1))
    hi = maximum_filter1d(y, size=size, axis=0, mode="nearest")
    lo = minimum_filter1d(y, size=size, axis=0, mode="nearest")
    return np.max(hi - lo, axis=0)
