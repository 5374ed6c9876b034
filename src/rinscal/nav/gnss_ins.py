"""Aided inertial navigation: a 15-state error-state Kalman filter over the strapdown, and
in-motion alignment from a reference track (GNSS, loosely coupled).

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
    measurement between two samples is linearised at the later one, the INS position
    carried to the measurement's time by its velocity). After every update
    the estimate is fed back (closed loop): position and velocity corrected, the attitude
    rotated by φ, the bias estimates grown by ``ε``, ``∇`` and subtracted from later
    increments; the error state returns to zero. Process noise: the IMU's white-noise
    densities and bias random walks (:class:`ImuNoise`, arguments, not a preset).

In-motion alignment (heading unknown)
    Chosen: optimisation-based alignment (OBA; Wu & Pan, IEEE TAES 49(2), 2013) in the
    velocity form, then the filter. Why: it needs no heading input and no assumption about
    how the IMU sits in the vehicle (no non-holonomic constraint, no encoder angle: a
    turntable turning the IMU is followed by the gyros), it works on any motion that has
    horizontal acceleration (speed changes or turns), and it is the moving-base twin of
    the inertial-frame coarse alignment already used at rest
    (:class:`rinscal.nav.align.InertialCoarseAlign`, whose :func:`~rinscal.nav.align.wahba`
    it reuses). Course over ground would need the IMU's mounting and a non-slipping
    vehicle, and roll and pitch from the mean specific force are wrong while the vehicle
    accelerates. With ``n0`` the navigation frame and ``r0`` the IMU frame at the start,
    both frozen in inertial space::

        C_n0n(t) f^n = d/dt (C_n0n v) + C_n0n (ω_ie^n × v − g^n)

    so ``α(t) = C_n0n(t) v(t) − v(0) + ∫ C_n0n (ω_ie^n × v − g^n) dτ`` (from the track:
    velocity by a five-point least-squares derivative of the fixes, ``C_n0n`` from Earth
    and transport rates) equals ``C_n0r0 β(t)`` with ``β(t) = ∫ C_r0r f^r dτ`` (from the
    IMU alone, coning and sculling as at rest). Wahba's problem over every fix of a
    ``coarse_s`` window gives ``C_n0r0``, the attitude at the window's start; gravity
    fixes roll and pitch, the horizontal velocity changes the heading (a straight drive
    at constant speed leaves it unobservable: :attr:`CoarseResult.heading_strength` says
    how much horizontal change there was). The filter then starts there (and so reuses
    the window's data, whose accelerations carry much of the heading) with the
    attitude uncertain by degrees and refines it from the track's positions: the
    accelerations of the drive make the heading error observable (``f^n × φ`` drives a
    velocity, hence position, error that the fixes see).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rinscal import earth
from rinscal.errors import ConfigError
from rinscal.nav import _kernels
from rinscal.nav.aiding import (
    ACCEL,
    ATT,
    GYRO,
    N_STATES,
    POS,
    VEL,
    GnssTrack,
    Linearised,
    Measurement,
    NavState,
    enu_difference,
)
from rinscal.nav.align import wahba
from rinscal.nav.strapdown import Strapdown, rotvec_to_dcm, skew


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
    i = 0
    for j, e in enumerate(ends):
        filt.propagate(dtheta[i:e], dv[i:e])
        i = int(e)
        lins = []
        for meas, k, tk in due.get(i, ()):
            lin = meas.linearise(k, filt.state(tk, tk - t[j]))
            if lin is not None:
                lins.append(lin)
        if lins:
            filt.update(lins)
            updated[j] = True
        nav = filt.nav
        rows[j, :3] = (nav.lat, nav.lon, nav.alt)
        rows[j, 3:] = nav.v_n
        C_all[j] = nav.C_nr
        sd[j] = np.sqrt(np.diag(filt.P))
        gb[j] = filt.gyro_bias
        ab[j] = filt.accel_bias
    return AidedResult(
        t, rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3:], C_all, sd, gb, ab, updated
    )


# --------------------------------------------------------------------------- in motion
@dataclass(frozen=True)
class CoarseResult:
    """Outcome of the optimisation-based coarse alignment in motion.

    Attributes
    ----------
    t : float [s]
        Time of the solution (a track fix).
    index : int
        Samples consumed up to ``t`` (sample ``index − 1`` ends at ``t``).
    lat, lon : float [rad]
        Track position at ``t``.
    alt : float [m]
    v_n : ndarray, shape (3,) [m/s]
        Track velocity at ``t`` (five-point least-squares derivative of the fixes).
    C_nr : ndarray, shape (3, 3)
        Attitude of ``r`` at ``t``.
    heading_strength : float [m/s]
        Second singular value of Wahba's matrix per fix, √(σ₂/m): the horizontal velocity
        change the heading was taken from (near zero: heading unobservable).
    """

    t: float
    index: int
    lat: float
    lon: float
    alt: float
    v_n: NDArray[np.float64]
    C_nr: NDArray[np.float64]
    heading_strength: float


def track_velocity(t: NDArray[np.float64], enu: NDArray[np.float64]) -> NDArray[np.float64]:
    """ENU velocity [m/s] at the fixes ``2 .. m−3`` by the five-point least-squares
    derivative ``(−2p₋₂ − p₋₁ + p₁ + 2p₂) / (10 Δt)`` of positions ``enu`` (m, 3) [m] at
    equally spaced times ``t`` (m,) [s]; noise ``σ/(√10 Δt)`` for white position noise σ."""
    step = float(np.median(np.diff(t)))
    p = enu
    return (-2.0 * p[:-4] - p[1:-3] + p[3:-1] + 2.0 * p[4:]) / (10.0 * step)


def coarse_in_motion(
    dtheta: NDArray[np.float64],
    dv: NDArray[np.float64],
    dt: float,
    t0: float,
    track: GnssTrack,
    coarse_s: float = 60.0,
) -> CoarseResult:
    """Attitude from increments and a position track, no heading given (OBA, module
    docstring).

    Parameters
    ----------
    dtheta, dv : ndarray, shape (n, 3) [rad], [m/s]
        Raw r-frame increments; sample ``i`` ends at ``t0 + (i + 1) dt`` (bias estimates,
        if any, already removed).
    dt : float [s]
        Sample interval.
    t0 : float [s]
        Start of the first sample.
    track : GnssTrack
        Positions at (nearly) equally spaced times; its lever arm is taken as zero here.
    coarse_s : float [s]
        Length of the window used.
    """
    n = dtheta.shape[0]
    tt = track.times
    sel = np.flatnonzero((tt >= t0 + dt) & (tt <= min(t0 + coarse_s, t0 + n * dt)))
    if sel.size < 8:
        raise ConfigError("in-motion alignment: needs at least 8 track fixes in the window")
    tk = tt[sel]
    lat, lon, alt = track.lat[sel], track.lon[sel], track.alt[sel]
    enu = enu_difference(lat, lon, alt, lat[0], lon[0], alt[0])
    v = track_velocity(tk, enu)
    t_w = tk[2:-2]  # the fixes with a velocity
    lat_w, alt_w = lat[2:-2], alt[2:-2]
    idx = np.rint((t_w - t0) / dt).astype(np.int64)
    m = t_w.size
    # n side: C_n0n at the fixes and α(t) (trapezoid for the integral)
    C_n0n = np.empty((m, 3, 3))
    C_n0n[0] = np.eye(3)
    integrand = np.empty((m, 3))
    for k in range(m):
        if k > 0:
            rn, re = earth.principal_radii(0.5 * (lat_w[k] + lat_w[k - 1]))
            vm = 0.5 * (v[k] + v[k - 1])
            la = 0.5 * (lat_w[k] + lat_w[k - 1])
            h = 0.5 * (alt_w[k] + alt_w[k - 1])
            w_in = earth.rate_n(la) + np.array(
                [-vm[1] / (rn + h), vm[0] / (re + h), vm[0] * math.tan(la) / (re + h)]
            )
            C_n0n[k] = C_n0n[k - 1] @ rotvec_to_dcm(w_in * (t_w[k] - t_w[k - 1]))
        minus_g = -earth.gravity_n(lat_w[k], alt_w[k])
        integrand[k] = C_n0n[k] @ (np.cross(earth.rate_n(lat_w[k]), v[k]) + minus_g)
    steps = np.diff(t_w)[:, None] * 0.5 * (integrand[1:] + integrand[:-1])
    alpha = np.einsum("kij,kj->ki", C_n0n, v) - v[0]
    alpha[1:] += np.cumsum(steps, axis=0)
    # r side: β(t) = ∫ C_r0r f^r dτ from the first fix with a velocity on
    q = np.array([1.0, 0.0, 0.0, 0.0])
    vsum = np.zeros(3)
    prev = np.zeros(7)
    beta = np.empty((m, 3))
    beta[0] = 0.0
    for k in range(1, m):
        _kernels.inertial_accumulate(
            q,
            vsum,
            prev,
            np.ascontiguousarray(dtheta[idx[k - 1] : idx[k]]),
            np.ascontiguousarray(dv[idx[k - 1] : idx[k]]),
        )
        beta[k] = vsum
    C_n0r0 = wahba(alpha, beta)
    sv = np.linalg.svd(alpha.T @ beta, compute_uv=False)
    # n0 and r0 are n and r at the first fix with a velocity: C_n0r0 is C_nr there
    return CoarseResult(
        t=float(t_w[0]),
        index=int(idx[0]),
        lat=float(lat_w[0]),
        lon=float(lon[2]),
        alt=float(alt_w[0]),
        v_n=v[0].copy(),
        C_nr=C_n0r0,
        heading_strength=float(math.sqrt(sv[1] / m)),
    )


@dataclass(frozen=True)
class InMotionResult:
    """In-motion alignment followed by aided navigation.

    Attributes
    ----------
    coarse : CoarseResult
        The coarse stage.
    aided : AidedResult
        The filter from the coarse solution on (its first step starts at ``coarse.t``).
    """

    coarse: CoarseResult
    aided: AidedResult


def navigate_aided(
    dtheta: NDArray[np.float64],
    dv: NDArray[np.float64],
    dt: float,
    track: GnssTrack,
    noise: ImuNoise,
    t0: float = 0.0,
    coarse_s: float = 60.0,
    initial: InitialSd | None = None,
    measurements: Sequence[Measurement] = (),
    step_s: float = 1.0,
) -> InMotionResult:
    """Align in motion on a track (no heading given), then navigate aided by it.

    Parameters
    ----------
    dtheta, dv : ndarray, shape (n, 3) [rad], [m/s]
        Raw r-frame increments; sample ``i`` ends at ``t0 + (i + 1) dt``.
    dt : float [s]
        Sample interval.
    track : GnssTrack
        The reference track (positions, optionally velocities), also the coarse
        stage's input.
    noise : ImuNoise
        The IMU's noise for the filter.
    t0 : float [s]
        Start of the first sample.
    coarse_s : float [s]
        Coarse (OBA) window.
    initial : InitialSd, optional
        Filter prior after the coarse stage; default: the track's σ in position,
        0.5 m/s, 0.5° level, 3° heading.
    measurements : sequence of Measurement
        Further aiding (a known site, zero velocity at stops, ...).
    step_s : float [s]
        Longest covariance propagation step.
    """
    coarse = coarse_in_motion(dtheta, dv, dt, t0, track, coarse_s)
    if initial is None:
        initial = InitialSd(
            position_sd=track.position_sd,
            velocity_sd=0.5,
            level_sd=math.radians(0.5),
            heading_sd=math.radians(3.0),
        )
    nav = Strapdown(coarse.lat, coarse.lon, coarse.alt, coarse.v_n, coarse.C_nr, dt, "free")
    filt = AidedInertial(nav, initial_covariance(initial, noise), noise)
    i = coarse.index
    aided = run_aided(filt, dtheta[i:], dv[i:], t0 + i * dt, [track, *measurements], step_s)
    return InMotionResult(coarse, aided)


__all__ = [
    "AidedInertial",
    "AidedResult",
    "CoarseResult",
    "ImuNoise",
    "InMotionResult",
    "InitialSd",
    "coarse_in_motion",
    "error_dynamics",
    "initial_covariance",
    "kalman_update",
    "navigate_aided",
    "process_noise",
    "run_aided",
    "track_velocity",
]
