"""Aided inertial navigation: a 15-state error-state Kalman filter over the strapdown, updated
by any :class:`rinscal.nav.aiding.Measurement` (GNSS loosely coupled, a site, zero velocity).

Filter
    The strapdown (:class:`rinscal.nav.strapdown.Strapdown`, vertical channel free)
    integrates the bias-compensated increments; an error-state Kalman filter on the 15
    states of :mod:`rinscal.nav.aiding` (position, velocity, attitude errors in ENU, gyro
    and accelerometer biases left in ``r``) propagates its covariance over blocks of at
    most ``step_s`` with the standard INS error model (Titterton & Weston, Groves Ch. 14;
    the attitude error ``C̃_nr = (I − [φ×]) C_nr`` of :mod:`rinscal.nav.align`)::

        δṙ = δv
        δv̇ = f^n × φ + C_nr ∇ − (2ω_ie^n + ω_en^n) × δv + (0, 0, 2g/R δr_U)
        φ̇  = −ω_in^n × φ + δω_in^n(δv, δr_N) − C_nr ε
        ε̇  = w_εb,  ∇̇ = w_∇b   (random walks; the white noises w_g, w_a drive φ and δv)

    discretised by the matrix exponential (Φ = exp(F T) to fourth order,
    Q_d = ½ (Φ Q Φᵀ + Q) T), and is updated by whatever
    :class:`rinscal.nav.aiding.Measurement` list it is given, each at its own times (a
    measurement between two samples is applied at the sample ending nearest to it, the
    INS position carried to the measurement's time by its velocity). After every update
    the estimate is fed back (closed loop): position and velocity corrected, the attitude
    rotated by φ, the bias estimates grown by ``ε``, ``∇`` and subtracted from later
    increments; the error state returns to zero. Process noise: the IMU's white-noise
    densities and bias random walks (:class:`ImuNoise`, arguments, not a preset).

In-motion alignment on a track, before this filter: :mod:`rinscal.nav.inmotion`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rinscal import earth
from rinscal.errors import ConfigError
from rinscal.nav.aiding import (
    ACCEL,
    ATT,
    GYRO,
    N_STATES,
    POS,
    VEL,
    Linearised,
    Measurement,
    NavState,
)
from rinscal.nav.strapdown import Strapdown, skew


@dataclass(frozen=True)
class ImuNoise:
    """The IMU's error model as the filter sees it (SI).

    Parameters
    ----------
    gyro_noise_density : float [rad/√s]
        Angle random walk (white rate noise density).
    accel_noise_density : float [m/s²/√Hz]
        Velocity random walk.
    gyro_bias_sd : float [rad/s]
        Prior standard deviation of each gyro bias.
    accel_bias_sd : float [m/s²]
        Prior standard deviation of each accelerometer bias.
    gyro_bias_rw : float [rad/s/√s]
        Random walk of each gyro bias (its driving noise density).
    accel_bias_rw : float [m/s²/√s]
        Random walk of each accelerometer bias.
    """

    gyro_noise_density: float
    accel_noise_density: float
    gyro_bias_sd: float
    accel_bias_sd: float
    gyro_bias_rw: float = 0.0
    accel_bias_rw: float = 0.0

    def __post_init__(self) -> None:
        for name in self.__dataclass_fields__:
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ConfigError(f"IMU noise: {name} must be >= 0, got {v}")


#: Heading uncertainty the filter starts with after a coarse or short alignment [rad] (3°):
#: wide enough for the linearised filter to pull in a heading the alignment got wrong by
#: several degrees (a 60 s zero-velocity alignment's own standard deviation can be far
#: too small: 0.5° given for a 15° error on the simulated vehicle drive of
#: tests/cli/test_cli_navigate_aiding.py).
HEADING_PRIOR_SD = math.radians(3.0)


@dataclass(frozen=True)
class InitialSd:
    """Prior standard deviations of the navigation errors at the filter's start.

    Parameters
    ----------
    position_sd : float [m]
        Each position coordinate.
    velocity_sd : float [m/s]
        Each velocity component.
    level_sd : float [rad]
        Tilt errors (east, north).
    heading_sd : float [rad]
        Heading (up) error.
    """

    position_sd: float
    velocity_sd: float
    level_sd: float
    heading_sd: float

    def __post_init__(self) -> None:
        for name in self.__dataclass_fields__:
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ConfigError(f"initial uncertainty: {name} must be > 0, got {v}")


def initial_covariance(initial: InitialSd, noise: ImuNoise) -> NDArray[np.float64]:
    """Diagonal prior covariance of the 15 error states (units squared, SI)."""
    sd = np.concatenate(
        [
            np.full(3, initial.position_sd),
            np.full(3, initial.velocity_sd),
            [initial.level_sd, initial.level_sd, initial.heading_sd],
            np.full(3, noise.gyro_bias_sd),
            np.full(3, noise.accel_bias_sd),
        ]
    )
    return np.diag(sd**2)


def error_dynamics(
    lat: float, alt: float, v_n: NDArray[np.float64], f_n: NDArray[np.float64], C_nr: ArrayLike
) -> NDArray[np.float64]:
    """System matrix ``F`` (15, 15) of the INS error model (module docstring).

    Parameters
    ----------
    lat : float [rad]
    alt : float [m]
    v_n : ndarray, shape (3,) [m/s]
        ENU velocity.
    f_n : ndarray, shape (3,) [m/s²]
        Specific force in ENU (mean over the step).
    C_nr : array_like, shape (3, 3)
        Attitude (mean over the step).
    """
    rn, re = earth.principal_radii(lat)
    RN, RE = float(rn) + alt, float(re) + alt
    cl, sl, tl = math.cos(lat), math.sin(lat), math.tan(lat)
    w_ie = earth.RATE * np.array([0.0, cl, sl])
    w_en = np.array([-v_n[1] / RN, v_n[0] / RE, v_n[0] * tl / RE])
    g = float(earth.gravity(lat, alt))
    C = np.asarray(C_nr, dtype=float)
    F = np.zeros((N_STATES, N_STATES))
    F[POS, VEL] = np.eye(3)
    F[VEL, ATT] = skew(f_n)
    F[VEL, VEL] = -skew(2.0 * w_ie + w_en)
    F[VEL, ACCEL] = C
    F[5, 2] = 2.0 * g / math.sqrt(RN * RE)
    F[ATT, ATT] = -skew(w_ie + w_en)
    F[6, 4] = -1.0 / RN
    F[7, 3] = 1.0 / RE
    F[8, 3] = tl / RE
    # δω_in from the latitude error δL = δr_N / R_N
    F[7, 1] = -earth.RATE * sl / RN
    F[8, 1] = (earth.RATE * cl + v_n[0] / (RE * cl * cl)) / RN
    F[ATT, GYRO] = -C
    return F


def transition(F: NDArray[np.float64], T: float, order: int = 4) -> NDArray[np.float64]:
    """``exp(F T)`` by its Taylor series to ``order`` (the INS error model's chain
    ε → φ → δv → δr is three long and its loops are slow, Earth rate and Schuler: the
    terms left out are below 1e-6 of those kept for steps of a second)."""
    A = F * T
    Phi = np.eye(F.shape[0]) + A
    term = A
    for k in range(2, order + 1):
        term = term @ A / k
        Phi += term
    return Phi


def process_noise(C_nr: ArrayLike, noise: ImuNoise) -> NDArray[np.float64]:
    """Continuous process noise density ``Q`` (15, 15) [state units²/s]."""
    C = np.asarray(C_nr, dtype=float)
    Q = np.zeros((N_STATES, N_STATES))
    Q[ATT, ATT] = noise.gyro_noise_density**2 * (C @ C.T)
    Q[VEL, VEL] = noise.accel_noise_density**2 * (C @ C.T)
    Q[GYRO, GYRO] = noise.gyro_bias_rw**2 * np.eye(3)
    Q[ACCEL, ACCEL] = noise.accel_bias_rw**2 * np.eye(3)
    return Q


def kalman_update(
    P: NDArray[np.float64], x: NDArray[np.float64], lin: Linearised
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """One (vector) measurement update in Joseph form.

    Returns
    -------
    P, x : updated covariance and error-state estimate
    nu : ndarray, shape (m,)
        The residual normalised by its predicted standard deviation (−).
    """
    H, R = lin.H, lin.R
    y = lin.residual - H @ x
    S = H @ P @ H.T + R
    K = np.linalg.solve(S, H @ P).T
    x = x + K @ y
    IKH = np.eye(P.shape[0]) - K @ H
    P = IKH @ P @ IKH.T + K @ R @ K.T
    return 0.5 * (P + P.T), x, y / np.sqrt(np.diag(S))


class AidedInertial:
    """A strapdown with a 15-state error-state Kalman filter, fed chunk by chunk.

    Parameters
    ----------
    nav : Strapdown
        The integrator at the start (its vertical channel should be ``"free"``: the
        filter holds it through the aiding).
    P0 : ndarray, shape (15, 15)
        Prior covariance (:func:`initial_covariance`).
    noise : ImuNoise
        Process noise.
    gyro_bias, accel_bias : array_like, shape (3,) [rad/s, m/s²]
        Initial bias estimates subtracted from the increments.
    """

    def __init__(
        self,
        nav: Strapdown,
        P0: NDArray[np.float64],
        noise: ImuNoise,
        gyro_bias: ArrayLike = (0.0, 0.0, 0.0),
        accel_bias: ArrayLike = (0.0, 0.0, 0.0),
    ) -> None:
        self.nav = nav
        self.P = np.array(P0, dtype=float)
        if self.P.shape != (N_STATES, N_STATES):
            raise ConfigError(f"aided INS: P0 must be ({N_STATES}, {N_STATES})")
        self.noise = noise
        self.gyro_bias = np.array(gyro_bias, dtype=float).reshape(3)
        self.accel_bias = np.array(accel_bias, dtype=float).reshape(3)
        self.omega_r = np.zeros(3)

    def propagate(
        self, dtheta: NDArray[np.float64], dv: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Integrate raw increments [rad], [m/s] (n, 3) and propagate the covariance over
        them as one step (keep steps short: a second or less).

        Returns
        -------
        ndarray, shape (15, 15)
            The step's transition matrix Φ of the error state.
        """
        n = dtheta.shape[0]
        if n == 0:
            return np.eye(N_STATES)
        dt = self.nav.dt
        T = n * dt
        d_th = dtheta - self.gyro_bias * dt
        d_v = dv - self.accel_bias * dt
        C0 = self.nav.C_nr
        self.nav.run(d_th, d_v)
        C = 0.5 * (C0 + self.nav.C_nr)
        f_n = C @ d_v.sum(axis=0) / T
        self.omega_r = d_th.sum(axis=0) / T
        F = error_dynamics(self.nav.lat, self.nav.alt, self.nav.v_n, f_n, C)
        Phi = transition(F, T)
        Q = process_noise(C, self.noise)
        self.P = Phi @ self.P @ Phi.T + 0.5 * (Phi @ Q @ Phi.T + Q) * T
        return Phi

    def state(self, t: float, tau: float = 0.0) -> NavState:
        """The INS solution at time ``t`` [s], its position carried ``tau`` [s] ahead by
        the velocity (a measurement taken between samples)."""
        nav = self.nav
        v = nav.v_n
        lat, lon, alt = nav.lat, nav.lon, nav.alt
        if tau != 0.0:
            rn, re = earth.principal_radii(lat)
            lat += v[1] * tau / (float(rn) + alt)
            lon += v[0] * tau / ((float(re) + alt) * math.cos(lat))
            alt += v[2] * tau
        return NavState(t, lat, lon, alt, v, nav.C_nr, self.omega_r.copy())

    def update(self, lins: Sequence[Linearised]) -> list[NDArray[np.float64]]:
        """Update with linearised measurements (one epoch) and feed the estimate back.

        Returns
        -------
        list of ndarray
            Each measurement's normalised residual.
        """
        x = np.zeros(N_STATES)
        out = []
        for lin in lins:
            self.P, x, nu = kalman_update(self.P, x, lin)
            out.append(nu)
        if lins:
            self.feed_back(x)
        return out

    def feed_back(self, x: NDArray[np.float64]) -> None:
        """Remove an error estimate ``x`` (15,) from the solution and the biases."""
        nav = self.nav
        lat, alt = nav.lat, nav.alt
        rn, re = earth.principal_radii(lat)
        nav.reset(
            lat=lat - x[1] / (float(rn) + alt),
            lon=nav.lon - x[0] / ((float(re) + alt) * math.cos(lat)),
            alt=alt - x[2],
        )
        nav.correct(phi_n=x[ATT], dv_n=x[VEL])
        self.gyro_bias += x[GYRO]
        self.accel_bias += x[ACCEL]


@dataclass(frozen=True)
class AidedResult:
    """The aided solution at the end of every filter step.

    Attributes
    ----------
    t : ndarray, shape (m,) [s]
    lat, lon : ndarray, shape (m,) [rad]
    alt : ndarray, shape (m,) [m]
    v_n : ndarray, shape (m, 3) [m/s]
    C_nr : ndarray, shape (m, 3, 3)
    sd : ndarray, shape (m, 15)
        Filter standard deviations of the error states (SI, :mod:`rinscal.nav.aiding`).
    gyro_bias, accel_bias : ndarray, shape (m, 3) [rad/s, m/s²]
        Bias estimates.
    updated : ndarray of bool, shape (m,)
        Whether a measurement was used at that step's end.
    residuals : dict of str to ndarray
        Per measurement class, its normalised residuals in time order, one row per use:
        each component over its predicted standard deviation (−); a consistent filter
        gives zero mean and unit variance.
    """

    t: NDArray[np.float64]
    lat: NDArray[np.float64]
    lon: NDArray[np.float64]
    alt: NDArray[np.float64]
    v_n: NDArray[np.float64]
    C_nr: NDArray[np.float64]
    sd: NDArray[np.float64]
    gyro_bias: NDArray[np.float64]
    accel_bias: NDArray[np.float64]
    updated: NDArray[np.bool_]
    residuals: dict[str, NDArray[np.float64]]


def run_aided(
    filt: AidedInertial,
    dtheta: NDArray[np.float64],
    dv: NDArray[np.float64],
    t0: float,
    measurements: Sequence[Measurement],
    step_s: float = 1.0,
) -> AidedResult:
    """Run an aided INS over increments, updating with every measurement in its time.

    Parameters
    ----------
    filt : AidedInertial
        The filter, its solution at ``t0``.
    dtheta, dv : ndarray, shape (n, 3) [rad], [m/s]
        Raw r-frame increments; sample ``i`` ends at ``t0 + (i + 1) dt``.
    t0 : float [s]
        Time of the filter's solution before the first sample.
    measurements : sequence of Measurement
        Aiding; those at times outside ``(t0, t0 + n dt]`` are ignored.
    step_s : float [s]
        Longest covariance propagation step.

    Returns
    -------
    AidedResult
        The solution after every step (after the update where there was one).
    """
    n = dtheta.shape[0]
    if dtheta.shape != (n, 3) or dv.shape != (n, 3):
        raise ConfigError("aided INS: dtheta and dv must both have shape (n, 3)")
    if not (math.isfinite(step_s) and step_s > 0):
        raise ConfigError(f"aided INS: step_s must be > 0, got {step_s}")
    dt = filt.nav.dt
    # sample count at which each measurement is used (the sample ending nearest to it)
    due: dict[int, list[tuple[Measurement, int, float]]] = {}
    for m in measurements:
        e = np.rint((np.asarray(m.times) - t0) / dt).astype(np.int64)
        for k in np.flatnonzero((e >= 1) & (e <= n)):
            due.setdefault(int(e[k]), []).append((m, int(k), float(m.times[k])))
    n_step = max(1, round(step_s / dt))
    ends = np.union1d(np.arange(n_step, n + 1, n_step), np.fromiter(due, np.int64, len(due)))
    if ends.size == 0 or ends[-1] != n:
        ends = np.append(ends, n)
    m_out = ends.size
    t = t0 + ends * dt
    rows = np.empty((m_out, 6))
    C_all = np.empty((m_out, 3, 3))
    sd = np.empty((m_out, N_STATES))
    gb = np.empty((m_out, 3))
    ab = np.empty((m_out, 3))
    updated = np.zeros(m_out, dtype=bool)
    residuals: dict[str, list[NDArray[np.float64]]] = {}
    i = 0
    for j, e in enumerate(ends):
        filt.propagate(dtheta[i:e], dv[i:e])
        i = int(e)
        lins, names = [], []
        for meas, k, tk in due.get(i, ()):
            lin = meas.linearise(k, filt.state(tk, tk - t[j]))
            if lin is not None:
                lins.append(lin)
                names.append(type(meas).__name__)
        if lins:
            for name, nu in zip(names, filt.update(lins), strict=True):
                residuals.setdefault(name, []).append(nu)
            updated[j] = True
        nav = filt.nav
        rows[j, :3] = (nav.lat, nav.lon, nav.alt)
        rows[j, 3:] = nav.v_n
        C_all[j] = nav.C_nr
        sd[j] = np.sqrt(np.diag(filt.P))
        gb[j] = filt.gyro_bias
        ab[j] = filt.accel_bias
    return AidedResult(
        t,
        rows[:, 0],
        rows[:, 1],
        rows[:, 2],
        rows[:, 3:],
        C_all,
        sd,
        gb,
        ab,
        updated,
        {name: np.vstack(v) for name, v in residuals.items()},
    )


__all__ = [
    "HEADING_PRIOR_SD",
    "AidedInertial",
    "AidedResult",
    "ImuNoise",
    "InitialSd",
    "error_dynamics",
    "initial_covariance",
    "kalman_update",
    "process_noise",
    "run_aided",
    "transition",
]
