"""Allan deviation of a static IMU record and the IEEE Std 952-1997 noise parameters.

:func:`allan_deviation` computes the **overlapping** Allan deviation
(NIST SP 1065 eq. 11, computed here in numpy; ``allantools.oadev`` with
``data_type="freq"`` is the test oracle) of one channel's output ``y`` sampled at
``rate_hz``, in the channel's own unit (deg/h, µg, rad/s, m/s², ...): the Allan deviation
of a rate is a rate. :func:`noise_parameters` reads from that curve, as in Annex C of IEEE
Std 952-1997, the three parameters a navigation engineer quotes:

============================  ==========  =====================  =========================
term                          ADEV slope  read                   unit (``u`` = y's unit)
============================  ==========  =====================  =========================
angle / velocity random walk  −1/2        ``N = σ(τ = 1 s)``     u·√s  (deg/h·√s, µg·√s)
bias instability              0           ``B = σ_min / 0.664``  u     (deg/h, µg)
rate random walk              +1/2        ``K = σ(τ = 3 s)``     u/√s  (deg/h/√s, µg/√s)
============================  ==========  =====================  =========================

where ``σ²(τ) = N²/τ + (2 ln 2/π) B² + K² τ/3`` for the three processes alone (the constant
``√(2 ln 2/π) = 0.664``). Conversions: a gyro's ARW in deg/h·√s divided by 60 is in
deg/√h; an accelerometer's VRW in µg·√s is numerically the noise density in µg/√Hz; a
rate random walk in deg/h/√s times 60 is in deg/h/√h.

Gaps (NaN samples)
    ``y`` is the uniformly sampled record, a NaN where a sample was dropped (rows of a log
    are never removed, so a dropped sample is a NaN at its place in time). The Allan
    variance is computed on **every contiguous NaN-free stretch separately and pooled**:
    at each averaging time, the squared second differences of all stretches long enough
    for it are averaged together (``σ² = Σ_s n_s σ_s² / Σ_s n_s``, ``n_s`` the number of
    overlapping differences of stretch ``s``). No difference ever spans a gap, nothing is
    interpolated, and no valid sample is thrown away (a stretch contributes at
    ``τ = m τ0`` once it has ``2m + 1`` samples, i.e. two overlapping differences; one of
    1 or 2 samples holds none); a step in the output across a gap (a power cycle, a
    re-mounted unit) does not enter the curve. The long averaging times come from the
    long stretches only (their confidence says so).

Confidence
    ``adev_err`` is IEEE 952's 1σ of an Allan deviation estimated from ``M`` independent
    clusters of ``τ = m τ0``, ``σ / √(2 (M − 1))`` (Annex C), with
    ``M = Σ_s ⌊n_samples_s / m⌋`` over the stretches. It is conservative for the
    overlapping estimator; allantools' own ``σ/√n_pairs`` treats the overlapping
    differences as independent and is ``√(m/2)`` times too optimistic at long τ.

The five terms fitted together
    :func:`fit_noise_terms` fits the whole IEEE 952 model, ``σ²(τ) = 3Q²/τ² + N²/τ +
    (2 ln 2/π) B² + K² τ/3 + R² τ²/2``, to every point of a curve by non-negative weighted
    least squares on the Allan variance, each point weighted by its clusters, with an
    exponentially correlated (Gauss-Markov) angle noise ``M`` of correlation time ``τc``
    kept where the information criterion says so (:func:`markov_angle_avar`), and says
    which terms the curve resolves and on which τ; ``N`` and ``K`` get upper bounds where it
    does not (a dithered laser gyro's white angle noise ``Q``, slope −1, and its correlated
    angle, slope −1/2 below τc, hiding the random walk on a 10 min record).
    :func:`noise_parameters` is the slope reading of Annex C, kept for the calibration
    report's table.

Why one module
    The Allan variance, its confidence (the clusters of each τ) and the two readings of it
    (slopes, fit) are one idea: the fit's weights and bounds are the curve's confidence, and
    both readings must agree on the same curve; split, they would share private helpers.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rinscal.calibration.regression import least_squares
from rinscal.errors import ConfigError

__all__ = [
    "BIAS_INSTABILITY_FACTOR",
    "MIN_CLUSTERS",
    "AllanCurve",
    "NoiseFit",
    "NoiseParameters",
    "NoiseTerm",
    "allan_deviation",
    "allan_deviations",
    "fit_noise_terms",
    "markov_angle_avar",
    "noise_parameters",
    "pool_curves",
]

#: ``√(2 ln 2 / π)``: the flat floor of the Allan deviation of flicker (1/f) noise of
#: bias instability ``B`` is ``0.664 B`` (IEEE Std 952-1997, Annex C).
BIAS_INSTABILITY_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)

#: Default tolerance on a local log-log slope (dimensionless): a point belongs to the
#: region of slope ``α`` (−1/2, 0, +1/2) when its local slope is within ``α ± 0.1``.
SLOPE_TOL = 0.1
#: Default largest relative 1σ error (dimensionless) of a point used to read a slope:
#: 0.1, i.e. at least 51 independent clusters of τ (τ ≤ record length / 51).
MAX_REL_ERR = 0.1

TausSpec = Literal["octave", "decade", "all"] | ArrayLike


@dataclass(frozen=True, eq=False)
class AllanCurve:
    """An overlapping Allan deviation curve of one channel.

    Parameters
    ----------
    tau_s : ndarray of float, shape (m,) [s]
        Averaging times, increasing; multiples of the sample interval ``1/rate_hz``.
    adev : ndarray of float, shape (m,) [unit of y]
        Overlapping Allan deviation at each ``tau_s``, in the unit of the samples
        (deg/h, µg, rad/s, m/s², ...).
    adev_err : ndarray of float, shape (m,) [unit of y]
        1σ uncertainty of ``adev``: ``adev / √(2 (M − 1))``, ``M`` the number of
        independent clusters of ``tau_s`` in the record (IEEE Std 952-1997; conservative
        for the overlapping estimator).
    n_pairs : ndarray of int, shape (m,)
        Number of overlapping second differences averaged at each ``tau_s``, summed over
        the NaN-free stretches of the record.
    clusters : ndarray of float, shape (m,), optional
        Number ``M`` of independent clusters of each ``tau_s`` (summed over stretches, and
        over channels for a pooled curve). Without it (a curve built by hand) it is read
        back from ``adev_err``: ``M = 1 + (adev/adev_err)²/2``.
    """

    tau_s: NDArray[np.float64]
    adev: NDArray[np.float64]
    adev_err: NDArray[np.float64]
    n_pairs: NDArray[np.int64]
    clusters: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        adev = np.array(self.adev, dtype=np.float64)
        err = np.array(self.adev_err, dtype=np.float64)
        if self.clusters is None:
            with np.errstate(divide="ignore", invalid="ignore"):
                m = 1.0 + 0.5 * (adev / err) ** 2
            clusters = np.where(np.isfinite(m), m, 1.0)
        else:
            clusters = np.array(self.clusters, dtype=np.float64)
        arrays = {
            "tau_s": np.array(self.tau_s, dtype=np.float64),
            "adev": adev,
            "adev_err": err,
            "n_pairs": np.array(self.n_pairs, dtype=np.int64),
            "clusters": clusters,
        }
        shape = arrays["tau_s"].shape
        if len(shape) != 1 or shape[0] == 0:
            raise ConfigError(f"AllanCurve tau_s must be a non-empty 1-D array, got {shape}")
        for name, a in arrays.items():
            if a.shape != shape:
                raise ConfigError(f"AllanCurve {name} has shape {a.shape}, tau_s {shape}")
            a.flags.writeable = False
            object.__setattr__(self, name, a)
        if not np.all(np.diff(arrays["tau_s"]) > 0) or arrays["tau_s"][0] <= 0:
            raise ConfigError("AllanCurve tau_s must be positive and increasing")

    def __len__(self) -> int:
        return int(self.tau_s.size)


@dataclass(frozen=True)
class NoiseParameters:
    """IEEE Std 952-1997 noise parameters read from an Allan deviation curve.

    ``u`` is the unit of the samples the curve was computed from (e.g. deg/h or µg). A
    parameter is None when the curve shows no (readable) region of its slope.

    Parameters
    ----------
    n : float or None [u·√s]
        Angle (gyro) or velocity (accelerometer) random walk: the slope −1/2 line read at
        τ = 1 s. deg/h·√s ÷ 60 = deg/√h; µg·√s = µg/√Hz; rad/s·√s = rad/√s.
    n_tau_s : tuple of float or None [s]
        First and last averaging time of the points the −1/2 line was fitted to.
    b : float or None [u]
        Bias instability: the minimum of the flat region divided by 0.664.
    b_tau_s : float or None [s]
        Averaging time of that minimum.
    k : float or None [u/√s]
        Rate random walk: the slope +1/2 line read at τ = 3 s. deg/h/√s × 60 = deg/h/√h;
        µg/√s × 60 = µg/√h.
    k_tau_s : tuple of float or None [s]
        First and last averaging time of the points the +1/2 line was fitted to.
    """

    n: float | None
    n_tau_s: tuple[float, float] | None
    b: float | None
    b_tau_s: float | None
    k: float | None
    k_tau_s: tuple[float, float] | None


# ---------------------------------------------------------------------------------------
# Allan deviation
# ---------------------------------------------------------------------------------------


def _check_rate(rate_hz: float) -> float:
    try:
        rate = float(rate_hz)
    except (TypeError, ValueError):
        raise ConfigError(f"rate_hz must be a positive number [Hz], got {rate_hz!r}") from None
    if not (math.isfinite(rate) and rate > 0):
        raise ConfigError(f"rate_hz must be a positive finite number [Hz], got {rate_hz!r}")
    return rate


def _samples(y: ArrayLike, name: str) -> NDArray[np.float64]:
    try:
        a = np.asarray(y, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{name} must be an array of numbers: {exc}") from None
    if a.ndim != 1:
        raise ConfigError(f"{name} must be 1-D (one channel), got shape {a.shape}")
    bad = np.flatnonzero(np.isinf(a))
    if bad.size:
        raise ConfigError(f"{name} holds ±inf at sample {int(bad[0])} (use NaN for a gap)")
    return a


def _stretches(a: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    """The contiguous NaN-free stretches of ``a``, in order (views)."""
    finite = np.isfinite(a)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], finite.view(np.int8), [0]))))
    return [a[lo:hi] for lo, hi in zip(edges[::2], edges[1::2], strict=True)]


def _m_grid(taus: Any, rate: float, m_max: int, longest: int, name: str) -> NDArray[np.int64]:
    """Averaging factors ``m`` (τ = m / rate) from a keyword or explicit τ [s]."""
    if isinstance(taus, str):
        if taus == "octave":
            m = 2 ** np.arange(m_max.bit_length())  # up to the largest power of 2 ≤ m_max
        elif taus == "decade":
            decades = 10 ** np.arange(len(str(m_max)))  # up to the largest power of 10 ≤ m_max
            m = (decades[:, None] * np.array([1, 2, 4])).ravel()
        elif taus == "all":
            m = np.arange(1, m_max + 1)
        else:
            raise ConfigError(
                f"taus must be 'octave', 'decade', 'all' or an array of τ [s], got {taus!r}"
            )
        return np.asarray(m[m <= m_max], dtype=np.int64)
    try:
        t = np.asarray(taus, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise ConfigError(f"taus must be a keyword or an array of τ [s], got {taus!r}") from None
    if t.size == 0 or not np.all(np.isfinite(t)):
        raise ConfigError(f"taus must be a non-empty array of finite τ [s], got {taus!r}")
    m = np.round(t * rate).astype(np.int64)
    if np.any(m < 1):
        raise ConfigError(
            f"taus: {float(t[np.argmin(m)]):g} s is shorter than the sample interval "
            f"{1.0 / rate:g} s"
        )
    if np.any(m > m_max):
        raise ConfigError(
            f"taus: {float(t[np.argmax(m)]):g} s needs {2 * int(m.max()) + 1} consecutive "
            f"finite samples; the longest NaN-free stretch of {name} has {longest}"
        )
    return np.unique(m)


def allan_deviation(y: ArrayLike, rate_hz: float, taus: TausSpec = "octave") -> AllanCurve:
    """Overlapping Allan deviation of one channel (as ``allantools.oadev`` of frequency data).

    Parameters
    ----------
    y : array_like, shape (n,) [u, e.g. deg/h, µg, rad/s, m/s²]
        Output samples, uniformly spaced at ``1/rate_hz``; NaN where a sample was dropped
        (each contiguous NaN-free stretch is analysed separately and the Allan variances
        pooled, see the module docstring). ±inf is an error.
    rate_hz : float [Hz]
        Sample rate.
    taus : {"octave", "decade", "all"} or array_like of float [s]
        Averaging times: ``m τ0`` with ``m`` = 1, 2, 4, 8, ... (``"octave"``), 1, 2, 4, 10,
        20, 40, ... (``"decade"``), every ``m`` (``"all"``: O(n²), short records only), or
        the given τ rounded to multiples of ``τ0 = 1/rate_hz``. Keywords stop at the
        longest τ with at least two overlapping differences in the longest stretch
        (``m ≤ (n_longest − 1)/2``); explicit τ beyond that are an error.

    Returns
    -------
    AllanCurve
        ``tau_s`` [s], ``adev`` and ``adev_err`` [u], ``n_pairs``.

    Raises
    ------
    rinscal.errors.ConfigError
        (a ``ValueError``) naming the parameter: ``y`` not 1-D, holding ±inf or without 3
        consecutive finite samples; ``rate_hz`` not positive; ``taus`` unknown or out of
        range.
    """
    rate = _check_rate(rate_hz)
    return _allan(_samples(y, "y"), rate, taus, "y")


def _oavar(s: NDArray[np.float64], rate: float, m: NDArray[np.int64]) -> NDArray[np.float64]:
    """Overlapping Allan variance of one NaN-free stretch at ``τ = m/rate`` [u²].

    The cumulative-sum (phase) form of NIST SP 1065 eq. (11), as ``allantools.oadev``
    computes it with ``data_type="freq"``: ``x_k = τ0 Σ_{j<k} (y_j − ȳ)`` (``x_0 = 0``,
    ``n + 1`` points), then ``σ²(m τ0) = Σ_i (x_{i+2m} − 2 x_{i+m} + x_i)² /
    (2 (m τ0)² (n + 1 − 2m))`` over the ``n + 1 − 2m`` overlapping second differences
    (each ``m ≤ (n − 1)/2``). The mean ``ȳ`` changes no second difference; removing it
    keeps ``x`` small. The squares are summed pairwise (``np.sum``), not by BLAS
    (``np.dot``), whose blocked sum lost 1e-13 relative on a 2-million-sample pulse record.
    One numpy pass per ``m``: O(n) per averaging time.
    """
    tau0 = 1.0 / rate
    x = np.empty(s.size + 1)
    x[0] = 0.0
    np.cumsum(s - s.mean(), out=x[1:])
    x *= tau0
    out = np.empty(m.size)
    for j, mj in enumerate(m.tolist()):
        mid = x[mj : x.size - mj]
        d = x[2 * mj :] - mid  # x_{i+2m} − 2 x_{i+m} + x_i, in place: one temporary
        d -= mid
        d += x[: x.size - 2 * mj]
        d *= d
        out[j] = float(np.sum(d)) / (2.0 * (mj * tau0) ** 2 * d.size)
    return out


def _allan(a: NDArray[np.float64], rate: float, taus: Any, name: str) -> AllanCurve:
    stretches = [s for s in _stretches(a) if s.size >= 3]
    longest = max((s.size for s in stretches), default=0)
    if longest < 3:
        n_finite = int(np.count_nonzero(np.isfinite(a)))
        raise ConfigError(
            f"{name} needs at least 3 consecutive finite samples for an Allan deviation; "
            f"it has {a.size} samples, {n_finite} finite, the longest NaN-free stretch "
            f"{max((s.size for s in _stretches(a)), default=0)}"
        )
    m_all = _m_grid(taus, rate, (longest - 1) // 2, longest, name)
    sum_sq = np.zeros(m_all.size)  # Σ n · σ² over stretches
    pairs = np.zeros(m_all.size, dtype=np.int64)
    clusters = np.zeros(m_all.size, dtype=np.int64)
    for s in stretches:
        use = m_all <= (s.size - 1) // 2  # ≥ 2 overlapping differences
        if not np.any(use):
            continue
        n_s = s.size + 1 - 2 * m_all[use]
        sum_sq[use] += n_s * _oavar(s, rate, m_all[use])
        pairs[use] += n_s
        clusters[use] += s.size // m_all[use]
    adev = np.sqrt(sum_sq / pairs)
    err = adev / np.sqrt(2.0 * np.maximum(clusters - 1, 1))
    return AllanCurve(tau_s=m_all / rate, adev=adev, adev_err=err, n_pairs=pairs, clusters=clusters)


def allan_deviations(
    data: Mapping[str, ArrayLike] | Any, rate_hz: float, taus: TausSpec = "octave"
) -> dict[str, AllanCurve]:
    """:func:`allan_deviation` of several channels at once.

    Parameters
    ----------
    data : mapping of str to array_like, or DataFrame
        Channel -> samples [its unit], all at ``rate_hz``; anything with ``.items()``
        (a dict of arrays, a pandas DataFrame of the channel columns).
    rate_hz : float [Hz]
        Sample rate.
    taus : {"octave", "decade", "all"} or array_like of float [s]
        As in :func:`allan_deviation`.

    Returns
    -------
    dict of str to AllanCurve
        One curve per channel, in the order of ``data``; error messages name the channel.
    """
    rate = _check_rate(rate_hz)
    out: dict[str, AllanCurve] = {}
    for ch, y in data.items():
        name = f"channel {ch!s}"
        out[str(ch)] = _allan(_samples(y, name), rate, taus, name)
    return out


# ---------------------------------------------------------------------------------------
# IEEE 952 noise parameters
# ---------------------------------------------------------------------------------------


def _local_slopes(log_t: NDArray[np.float64], log_s: NDArray[np.float64]) -> NDArray[np.float64]:
    """Least-squares slope of ``log σ`` vs ``log τ`` about each point.

    Over the points within a factor 2 of its τ, and always its nearest neighbour on each
    side (so that a decade grid still has slopes); NaN for a lone point.
    """
    n = log_t.size
    out = np.full(n, np.nan)
    half = math.log(2.0) * (1.0 + 1e-9)
    for i in range(n):
        sel = np.abs(log_t - log_t[i]) <= half
        sel[max(i - 1, 0) : i + 2] = True
        if np.count_nonzero(sel) < 2:
            continue
        x = log_t[sel] - log_t[sel].mean()
        out[i] = float(np.dot(x, log_s[sel] - log_s[sel].mean()) / np.dot(x, x))
    return out


def _fixed_slope_line(
    log_t: NDArray[np.float64], log_s: NDArray[np.float64], w: NDArray[np.float64], slope: float
) -> float:
    """log σ at log τ = 0 of the weighted least-squares line of the given slope."""
    return float(np.sum(w * (log_s - slope * log_t)) / np.sum(w))


def noise_parameters(
    curve: AllanCurve, *, slope_tol: float = SLOPE_TOL, max_rel_err: float = MAX_REL_ERR
) -> NoiseParameters:
    """Read N, B and K from an Allan deviation curve by the IEEE Std 952-1997 slopes.

    Rules (Annex C; ``u`` is the unit of the curve):

    1. Only points whose relative 1σ error ``adev_err / adev`` is at most ``max_rel_err``
       are read (default 0.1: at least 51 independent clusters); the tail beyond is too
       uncertain to tell a slope from (the slope between neighbouring octaves is then
       known to about ±``max_rel_err``).
    2. The local slope at each point is the least-squares slope of ``log σ`` against
       ``log τ`` over the readable points within a factor 2 of its τ (on an octave grid:
       its two neighbours).
    3. A point is in the region of slope ``α`` when ``|local slope − α| ≤ slope_tol``
       (default 0.1). At the edge of a ±1/2 region the neighbouring process already
       raises σ there, by about 5 % (the opposite ±1/2 process) to 12 % (a flicker
       floor) at tol = 0.1, so N and K can read a few per cent high where processes meet
       (less than that: the fit spans the whole region).
    4. ``N``: the line of slope −1/2 fitted (weighted by ``1/rel_err²``) to the −1/2 region,
       read at τ = 1 s (extrapolated along the line if needed): ``N = σ(1 s)`` [u·√s].
    5. ``K``: the line of slope +1/2 fitted likewise to the +1/2 region, read at τ = 3 s:
       ``K = σ(3 s)`` [u/√s].
    6. ``B``: the smallest σ of the flat region (slope 0 ± ``slope_tol``) divided by 0.664;
       without a flat point, the curve's minimum when it is a bottom, i.e. readable points
       before it fall (slope < −tol) and readable points after it rise (slope > +tol) —
       white noise plus rate random walk without flicker reads the bottom of their bowl,
       an upper bound of any flicker floor. ``b_tau_s`` [s] is the τ of that minimum.

    Parameters
    ----------
    curve : AllanCurve
        From :func:`allan_deviation`, in unit ``u``.
    slope_tol : float
        Tolerance on the local log-log slope (dimensionless), in (0, 0.25).
    max_rel_err : float
        Largest relative 1σ error of a point used (dimensionless), > 0.

    Returns
    -------
    NoiseParameters
        ``n`` [u·√s], ``b`` [u], ``k`` [u/√s] (each None without its region) and the τ
        [s] they were read from.
    """
    if not (0 < slope_tol < 0.25):
        raise ConfigError(f"slope_tol must be in (0, 0.25), got {slope_tol!r}")
    if not (max_rel_err > 0):
        raise ConfigError(f"max_rel_err must be positive, got {max_rel_err!r}")
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = curve.adev_err / curve.adev
    use = (curve.adev > 0) & np.isfinite(rel) & (rel <= max_rel_err)
    none = NoiseParameters(None, None, None, None, None, None)
    if np.count_nonzero(use) < 2:
        return none
    tau = curve.tau_s[use]
    sig = curve.adev[use]
    log_t, log_s = np.log(tau), np.log(sig)
    w = 1.0 / rel[use] ** 2
    slope = _local_slopes(log_t, log_s)

    n = n_tau = k = k_tau = b = b_tau = None
    white = np.abs(slope + 0.5) <= slope_tol
    if np.any(white):
        n = math.exp(_fixed_slope_line(log_t[white], log_s[white], w[white], -0.5))
        n_tau = (float(tau[white][0]), float(tau[white][-1]))
    rrw = np.abs(slope - 0.5) <= slope_tol
    if np.any(rrw):
        at_1s = _fixed_slope_line(log_t[rrw], log_s[rrw], w[rrw], 0.5)
        k = math.exp(at_1s + 0.5 * math.log(3.0))
        k_tau = (float(tau[rrw][0]), float(tau[rrw][-1]))
    flat = np.abs(slope) <= slope_tol
    i_min: int | None = None
    if np.any(flat):
        idx = np.flatnonzero(flat)
        i_min = int(idx[np.argmin(sig[idx])])
    else:
        i = int(np.argmin(sig))
        if np.any(slope[:i] < -slope_tol) and np.any(slope[i + 1 :] > slope_tol):
            i_min = i
    if i_min is not None:
        b = float(sig[i_min]) / BIAS_INSTABILITY_FACTOR
        b_tau = float(tau[i_min])
    return NoiseParameters(n=n, n_tau_s=n_tau, b=b, b_tau_s=b_tau, k=k, k_tau_s=k_tau)


# ---------------------------------------------------------------------------------------
# IEEE 952 terms fitted to the whole curve
# ---------------------------------------------------------------------------------------

#: Fewest independent clusters (dimensionless) of a point that may show a term dominating
#: or bound the random walk: 10 (relative 1σ of the deviation 1/√18 = 24 %).
MIN_CLUSTERS = 10.0
#: How many 1σ of the deviation a bound adds (dimensionless): 2, so that the truth lies
#: under it about 98 % of the time (1σ left it under in only 84 %).
BOUND_SIGMAS = 2.0
#: Largest relative 1σ (dimensionless) of a fitted term's value that makes it resolved.
RESOLVED_REL_SD = 0.3
#: A term dominating somewhere is resolved if its relative 1σ is at most this.
DOMINANT_REL_SD = 0.5
#: Correlation times τc [s] tried for the exponentially correlated angle noise: 8 a decade
#: from 5 to 500 s, those within the τ of the points fitted.
MARKOV_TAU_C_GRID_S = tuple(float(t) for t in np.geomspace(5.0, 500.0, 17))

#: The IEEE 952 terms in the fit: name, power of τ in σ²(τ), coefficient, and what it is.
_TERMS: tuple[tuple[str, int, float, str], ...] = (
    ("q", -2, 3.0, "white angle (velocity) noise / quantisation"),
    ("n", -1, 1.0, "angle (velocity) random walk"),
    ("b", 0, BIAS_INSTABILITY_FACTOR**2, "bias instability"),
    ("k", 1, 1.0 / 3.0, "rate random walk"),
    ("r", 2, 0.5, "rate ramp"),
)


def markov_angle_avar(tau_s: ArrayLike, tau_c_s: float) -> NDArray[np.float64]:
    """Allan variance [1/s²] of a rate whose angle is Gauss-Markov noise of unit sd.

    An angle of stationary sd ``M`` and autocovariance ``M² e^{−|s|/τc}`` (the slowly
    wandering dither residual of a laser gyro; IEEE 952 Annex C's exponentially correlated
    noise, on the angle): the rate averaged over τ is ``(θ(t+τ) − θ(t))/τ``, so
    ``σ²(τ) = E[(θ₂ − 2θ₁ + θ₀)²]/(2τ²) = M² (3 − 4e^{−τ/τc} + e^{−2τ/τc})/τ²``; this is
    that, for ``M = 1``. For τ ≪ τc it is an angle random walk of ``N² = 2M²/τc`` (slope
    −1/2), for τ ≫ τc white angle noise of ``Q = M`` (slope −1).
    """
    t = np.asarray(tau_s, dtype=np.float64)
    x = t / float(tau_c_s)
    return np.asarray((np.expm1(-2.0 * x) - 4.0 * np.expm1(-x)) / t**2, dtype=np.float64)


@dataclass(frozen=True)
class NoiseTerm:
    """One term fitted to an Allan variance curve (``u`` the unit of the curve).

    Attributes
    ----------
    name : {"q", "n", "b", "k", "r", "m"}
        Quantisation / white angle noise ``Q`` [u·s], angle random walk ``N`` [u·√s], bias
        instability ``B`` [u], rate random walk ``K`` [u/√s], rate ramp ``R`` [u/s],
        exponentially correlated angle noise ``M`` [u·s] (its stationary sd; its
        correlation time is :attr:`NoiseFit.tau_c_s`).
    value : float
        The fitted value (≥ 0; 0 where the fit put none).
    sd : float
        Its 1σ, over the models the criterion weighs (``inf`` where the curve cannot tell).
    resolved : bool
        The curve determines it: relative 1σ ≤ :data:`RESOLVED_REL_SD`, or it is the
        largest term at some τ with at least :data:`MIN_CLUSTERS` clusters and its relative
        1σ ≤ :data:`DOMINANT_REL_SD` (``N`` only by the first rule where ``M`` is fitted).
    dominant_tau_s : tuple of float or None [s]
        First and last τ (with enough clusters) where its contribution to σ² is the largest.
    bound : float or None
        Upper bound on the term from the curve alone (``N`` and ``K``, whatever the other
        terms), each σ raised by its 1σ: ``N ≤ σ(τ)·√τ`` at the longest τ with enough
        clusters, ``K ≤ σ(τ)·√(3/τ)`` at the τ with enough clusters that gives the smallest.
    bound_tau_s : float or None [s]
        The τ of that bound.
    """

    name: str
    value: float
    sd: float
    resolved: bool
    dominant_tau_s: tuple[float, float] | None = None
    bound: float | None = None
    bound_tau_s: float | None = None

    @property
    def rel_sd(self) -> float:
        """``sd / value`` (``inf`` for a zero value)."""
        return self.sd / self.value if self.value > 0 else math.inf


@dataclass(frozen=True)
class NoiseFit:
    """The IEEE 952 terms fitted to one Allan curve, and what the curve could show.

    Attributes
    ----------
    q, n, b, k, r, m : NoiseTerm
        See :class:`NoiseTerm` (``m`` zero where the correlated angle noise was not kept).
    tau_s : tuple of float [s]
        First and last τ of the points fitted.
    tau_reliable_s : float [s]
        Longest τ with at least :data:`MIN_CLUSTERS` clusters.
    points : int
        Points fitted.
    chi2_dof : float
        Weighted residual sum of squares per degree of freedom of the model kept (≈ 1 when
        the model and the confidence agree; below 1 is usual, the points being correlated).
    tau_c_s : float or None [s]
        Correlation time of ``m`` where it was kept, else None.
    tau_c_range_s : tuple of float or None [s]
        Its 1σ range (the criterion's weights over the τc grid, in log τc).
    markov_weight : float
        The criterion's weight of the models with ``m`` (0-1; kept above 1/2).
    """

    q: NoiseTerm
    n: NoiseTerm
    b: NoiseTerm
    k: NoiseTerm
    r: NoiseTerm
    tau_s: tuple[float, float]
    tau_reliable_s: float
    points: int
    chi2_dof: float
    m: NoiseTerm = NoiseTerm("m", 0.0, math.inf, False)
    tau_c_s: float | None = None
    tau_c_range_s: tuple[float, float] | None = None
    markov_weight: float = 0.0

    @property
    def terms(self) -> tuple[NoiseTerm, ...]:
        return (self.q, self.n, self.b, self.k, self.r, self.m)

    def n_for_filter(self) -> tuple[float, bool]:
        """The random walk a filter should assume: the fit's ``N`` (unresolved: at most its
        bound); the bound where the fit put none.

        Returns ``(value [u·√s], resolved)``. An unresolved ``N`` that the fit puts above
        zero is still the curve's best estimate: on a 10 min window of a dithered laser
        gyro it holds the correlated angle noise that the window cannot tell from it (up
        to 2×), its bound more (2.5×); told to an alignment filter, the bound gave the
        larger heading errors (``docs/navigation.md``, *The filter's noise*). Where the
        fit put no ``N`` (white angle noise all the way), the bound, the safe side.
        """
        if self.n.bound is None or self.n.resolved:
            return self.n.value, self.n.resolved
        if self.n.value > 0:  # never above what the curve allows
            return min(self.n.value, self.n.bound), False
        return self.n.bound, False

    def model(self, tau_s: ArrayLike) -> NDArray[np.float64]:
        """The fitted Allan deviation at ``tau_s`` [s] (unit of the curve)."""
        t = np.asarray(tau_s, dtype=np.float64)
        five = self.terms[:5]
        var = sum(c * e.value**2 * t**p for (_, p, c, _), e in zip(_TERMS, five, strict=True))
        if self.tau_c_s is not None:
            var = var + self.m.value**2 * markov_angle_avar(t, self.tau_c_s)
        return np.sqrt(var)


def pool_curves(curves: list[AllanCurve] | tuple[AllanCurve, ...]) -> AllanCurve:
    """One curve of several channels of the same noise: the mean Allan variance.

    The channels (e.g. the three axes of a gyro triad) must share the τ grid; their
    variances are averaged and their clusters summed (independent channels), so the result
    is the curve of the channels' mean-square noise with the confidence of all of them.
    """
    if not curves:
        raise ConfigError("pool_curves needs at least one curve")
    tau = curves[0].tau_s
    for c in curves[1:]:
        if c.tau_s.shape != tau.shape or not np.allclose(c.tau_s, tau):
            raise ConfigError("pool_curves: the curves must share their averaging times")
    var = np.mean([c.adev**2 for c in curves], axis=0)
    clusters = np.sum([c.clusters for c in curves], axis=0)
    adev = np.sqrt(var)
    err = adev / np.sqrt(2.0 * np.maximum(clusters - 1.0, 1.0))
    pairs = np.sum([c.n_pairs for c in curves], axis=0)
    return AllanCurve(tau_s=tau, adev=adev, adev_err=err, n_pairs=pairs, clusters=clusters)


def _nnls(a: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Non-negative least squares ``min ‖a x − y‖, x ≥ 0`` of a few unknowns, exactly.

    The solution is the unconstrained least squares on its own support (the terms it
    keeps); with five or six terms every support is tried and the best feasible one kept.
    Columns are scaled to unit norm first (the terms differ by many decades).
    """
    k = a.shape[1]
    scale = np.linalg.norm(a, axis=0)
    scale[scale == 0] = 1.0
    b = a / scale
    best = np.zeros(k)
    best_r = float(np.dot(y, y))
    for mask in range(1, 2**k):
        cols = [j for j in range(k) if mask >> j & 1]
        sol = least_squares(b[:, cols], y)
        if np.any(sol <= 0):
            continue
        r = y - b[:, cols] @ sol
        rr = float(np.dot(r, r))
        if rr < best_r:
            best_r = rr
            best = np.zeros(k)
            best[cols] = sol
    return np.asarray(best / scale, dtype=np.float64)


def _cov(a: NDArray[np.float64], cols: list[int]) -> NDArray[np.float64]:
    """Covariance of the parameters ``cols`` of the whitened system ``a`` (pinv)."""
    sub = a[:, cols]
    return np.asarray(np.linalg.pinv(sub.T @ sub), dtype=np.float64)


def _fit_linear(
    basis: NDArray[np.float64], y: NDArray[np.float64], dof_w: NDArray[np.float64], iters: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], float, int]:
    """Iteratively reweighted NNLS of ``y = basis θ``: ``(θ, var θ, χ², terms kept)``."""
    model = y.copy()
    x = np.zeros(basis.shape[1])
    for _ in range(max(1, int(iters))):
        s = model / np.sqrt(dof_w)  # 1σ of each σ² point
        x = _nnls(basis / s[:, None], y / s)
        fitted = basis @ x
        model = np.where(fitted > 0, fitted, y)  # a point the model calls zero: its own
    s = model / np.sqrt(dof_w)
    aw = basis / s[:, None]
    chi2 = float(np.sum(((y - basis @ x) / s) ** 2))
    active = [j for j in range(x.size) if x[j] > 0]
    inflate = max(chi2 / max(y.size - len(active), 1), 1.0)
    var = np.full(x.size, np.inf)
    if active:
        var[active] = np.diag(_cov(aw, active)) * inflate
    for j in range(x.size):
        if j not in active:  # the 1σ it would have had if freed alone
            var[j] = _cov(aw, [*active, j])[-1, -1] * inflate
    return x, var, chi2, len(active)


def fit_noise_terms(
    curve: AllanCurve,
    *,
    min_clusters: float = MIN_CLUSTERS,
    iterations: int = 4,
    correlated: bool = True,
) -> NoiseFit:
    """Fit the IEEE Std 952-1997 model, and a correlated angle noise, to an Allan curve.

    The model (IEEE Std 952-1997 Annex C, eq. C.15; El-Sheimy, Hou & Niu 2008, IEEE Trans.
    Instrum. Meas. 57(1), Table I) is the sum of the Allan variances of independent
    processes, ``u`` the unit of the curve (a rate):

    ``σ²(τ) = 3Q²/τ² + N²/τ + (2 ln 2/π) B² + K² τ/3 + R² τ²/2
    [+ M² (3 − 4e^{−τ/τc} + e^{−2τ/τc})/τ²]``

    with ``Q`` the quantisation / white angle noise [u·s] (slope −1: a pulse-output gyro's
    count, a dithered laser gyro's angle noise, an accelerometer's velocity count), ``N``
    the angle (velocity) random walk [u·√s] (slope −1/2), ``B`` the bias instability [u]
    (flat; exact only well inside the flicker band), ``K`` the rate random walk [u/√s]
    (+1/2), ``R`` the rate ramp [u/s] (+1) and ``M`` an exponentially correlated
    (Gauss-Markov) angle noise [u·s] of correlation time ``τc`` (:func:`markov_angle_avar`;
    a dithered laser gyro's slowly wandering angle: for τ ≪ τc it looks exactly like a
    random walk of ``√2 M/√τc``, and only the bend at τ ≈ τc tells it from ``N``). For a
    given τc the model is linear in ``(Q², N², B², K², R², M²)``, found by **non-negative
    weighted least squares** on the Allan *variance* of every point (a point's weight is
    its confidence: the variance of an Allan variance from ``M`` clusters is
    ``2σ⁴/(M − 1)``, σ the model's, iteratively reweighted). Each term's covariance is the
    inverse normal matrix, scaled by the residual χ² per degree of freedom where above 1;
    a term the fit put at zero gets the 1σ it would have had if freed alone.

    **Whether ``M`` is there, and its τc** (``correlated``): the five-term model and the
    six-term model at every τc of :data:`MARKOV_TAU_C_GRID_S` within the curve's τ are
    fitted and weighed by the Bayesian information criterion ``BIC = χ²/ĉ + p ln n``
    (``n`` points, ``p`` = 5 parameters without ``M``, 7 with ``M`` and τc; ``ĉ`` the
    six-term model's best χ² per degree of freedom where above 1, as a quasi-likelihood
    allows for correlated points): model ``j`` gets the weight ``∝ π_j e^{−BIC_j/2}``, the
    prior ``π`` one half without ``M`` and one half spread evenly over the τc grid. ``M``
    is kept where the models with it weigh more than one half, at the τc of the largest
    weight; the values reported are that model's. Each term's 1σ is taken over all the
    models by their weights (``var = Σ w_j (var_j + (θ_j − θ)²)``), so a random walk that
    the correlated noise can stand in for (another τc, another ``M``) is not resolved.

    What the curve shows (:class:`NoiseTerm`): a term is *resolved* when its relative 1σ is
    at most 30 %, or when it dominates σ² somewhere among the points with at least
    ``min_clusters`` clusters and its relative 1σ is at most 50 % (``N`` where ``M`` is
    kept: only the first). ``N`` and ``K`` also get bounds from the curve alone: every term
    adds to σ², so ``N²/τ ≤ σ²(τ)`` and ``K²τ/3 ≤ σ²(τ)`` at every τ; the bound is
    ``(σ + 2σ)·√τ`` at the longest τ with enough clusters (``K``: the smallest
    ``(σ + 2σ)·√(3/τ)`` over those points; :data:`BOUND_SIGMAS`).

    Parameters
    ----------
    curve : AllanCurve
        From :func:`allan_deviation` or :func:`pool_curves`, in unit ``u``; points with
        ``σ = 0`` or fewer than 2 clusters are left out.
    min_clusters : float
        Clusters a point needs to show a dominating term or give a bound (default 10).
    iterations : int
        Reweighting passes (≥ 1).
    correlated : bool
        Weigh the correlated angle noise ``M`` (default True); False: the five terms only.

    Returns
    -------
    NoiseFit

    Raises
    ------
    rinscal.errors.ConfigError
        Fewer than 2 usable points.
    """
    if not (min_clusters >= 2):
        raise ConfigError(f"min_clusters must be at least 2, got {min_clusters!r}")
    use = (curve.adev > 0) & np.isfinite(curve.adev) & (curve.clusters >= 2)
    if np.count_nonzero(use) < 2:
        raise ConfigError(
            f"an IEEE 952 fit needs at least 2 points with 2 clusters; the curve has "
            f"{int(np.count_nonzero(use))} of {len(curve)}"
        )
    tau = curve.tau_s[use]
    sig = curve.adev[use]
    m = curve.clusters[use]
    y = sig**2
    dof_w = np.maximum(m - 1.0, 1.0) / 2.0  # 1 / relative variance of σ²
    base = np.stack([c * tau**p for _, p, c, _ in _TERMS], axis=1)
    grid = [tc for tc in MARKOV_TAU_C_GRID_S if tau[0] <= tc <= tau[-1]] if correlated else []
    bases = [np.column_stack([base, np.zeros(tau.size)])]
    bases += [np.column_stack([base, markov_angle_avar(tau, tc)]) for tc in grid]
    fits = [_fit_linear(b, y, dof_w, iterations) for b in bases]
    theta = np.array([f[0] for f in fits])
    var = np.array([f[1] for f in fits])
    theta[0, -1] = var[0, -1] = 0.0  # no M in the five-term model
    chi2 = np.array([f[2] for f in fits])
    n_pts = tau.size
    c_hat = 1.0
    if grid:
        j6 = 1 + int(np.argmin(chi2[1:]))
        c_hat = max(1.0, chi2[j6] / max(n_pts - fits[j6][3] - 1, 1))
    bic = chi2 / c_hat + np.array([5.0] + [7.0] * len(grid)) * math.log(n_pts)
    prior = np.array([0.5] + [0.5 / len(grid)] * len(grid)) if grid else np.ones(1)
    w = prior * np.exp(-0.5 * (bic - bic.min()))
    w /= w.sum()
    w_markov = float(w[1:].sum())
    sel = 1 + int(np.argmax(w[1:])) if w_markov > 0.5 else 0
    x = theta[sel]
    keep = w > 1e-12
    var_x = np.sum(w[keep, None] * (var[keep] + (theta[keep] - x) ** 2), axis=0)
    if grid:  # N with the correlated noise in the model, whatever was kept: at its best τc,
        # and as far as another τc the curve allows (χ² within 1 of the best) moves it
        near = chi2[1:] <= chi2[j6] + c_hat
        spread = float(np.max((theta[1:, 1][near] - x[1]) ** 2))
        var_x[1] = max(var_x[1], float(var[j6, 1] + (theta[j6, 1] - x[1]) ** 2), spread)
    tau_c = tau_c_range = None
    if sel:
        tau_c = grid[sel - 1]
        lt, wm = np.log(grid), w[1:] / w_markov
        mu = float(np.sum(wm * lt))
        sd_lt = math.sqrt(float(np.sum(wm * (lt - mu) ** 2)))
        tau_c_range = (math.exp(mu - sd_lt), math.exp(mu + sd_lt))
    chi2_dof = float(chi2[sel] / max(n_pts - fits[sel][3] - (1 if sel else 0), 1))

    reliable = m >= min_clusters
    tau_rel = float(tau[reliable][-1]) if np.any(reliable) else float(tau[0])
    contrib = bases[sel] * x  # each term's σ² at each point
    largest = np.argmax(contrib, axis=1)
    upper = sig * (1.0 + BOUND_SIGMAS / np.sqrt(2.0 * np.maximum(m - 1.0, 1.0)))
    terms: dict[str, NoiseTerm] = {}
    for j, (name, power) in enumerate([(t[0], t[1]) for t in _TERMS] + [("m", None)]):
        value = math.sqrt(x[j])
        sd_theta = math.sqrt(var_x[j]) if np.isfinite(var_x[j]) else math.inf
        # σ of √θ: sd_θ / (2√θ) where θ > 0; at θ = 0 the 1σ of √θ is √(sd_θ)
        sd = sd_theta / (2.0 * value) if value > 0 else math.sqrt(sd_theta)
        dom = reliable & (largest == j) & (x[j] > 0)
        dom_tau = (float(tau[dom][0]), float(tau[dom][-1])) if np.any(dom) else None
        rel = sd / value if value > 0 else math.inf
        by_dominance = dom_tau is not None and rel <= DOMINANT_REL_SD
        if name == "n" and grid:
            by_dominance = False  # a random walk the correlated noise can stand in for
        resolved = value > 0 and (rel <= RESOLVED_REL_SD or by_dominance)
        bound = bound_tau = None
        if power in (-1, 1) and np.any(reliable):
            b_all = upper / np.sqrt(_TERMS[j][2] * tau**power)
            b_all = np.where(reliable, b_all, np.inf)
            # N: at the longest reliable τ (the smallest of many noisy points is biased low)
            i = int(np.flatnonzero(reliable)[-1]) if power == -1 else int(np.argmin(b_all))
            bound, bound_tau = float(b_all[i]), float(tau[i])
        terms[name] = NoiseTerm(name, value, sd, bool(resolved), dom_tau, bound, bound_tau)
    return NoiseFit(
        **terms,
        tau_s=(float(tau[0]), float(tau[-1])),
        tau_reliable_s=tau_rel,
        points=int(n_pts),
        chi2_dof=chi2_dof,
        tau_c_s=tau_c,
        tau_c_range_s=tau_c_range,
        markov_weight=w_markov,
    )
