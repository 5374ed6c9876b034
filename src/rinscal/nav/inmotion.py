"""In-motion alignment on a reference track (GNSS), heading unknown, then aided navigation.

Method
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
from numpy.typing import NDArray

from rinscal import _kernels, earth
from rinscal.errors import ConfigError
from rinscal.nav.aiding import GnssTrack, Measurement, enu_difference
from rinscal.nav.align import AlignResult, wahba
from rinscal.nav.gnss_ins import (
    HEADING_PRIOR_SD,
    AidedInertial,
    AidedResult,
    ImuNoise,
    InitialSd,
    initial_covariance,
    run_aided,
)
from rinscal.nav.strapdown import Strapdown, rotvec_to_dcm


@dataclass(frozen=True)
class CoarseResult:
    """Outcome of the optimisation-based coarse alignment in motion.

    Attributes
    ----------
    t : float [s]
        Time of the solution (a track fix).
    index : int
        Samples consumed up to ``t`` (sample ``index − 1`` ends nearest to ``t``).
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
        Positions at (nearly) equally spaced times; its velocities, if it has them, are
        used instead of the positions' derivative; its lever arm is taken as zero here.
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
    if track.v_n is None:
        v = track_velocity(tk, enu_difference(lat, lon, alt, lat[0], lon[0], alt[0]))
    else:  # the track's own velocities, on the same fixes as the derivative's
        v = track.v_n[sel][2:-2]
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
            heading_sd=HEADING_PRIOR_SD,
        )
    nav = Strapdown(coarse.lat, coarse.lon, coarse.alt, coarse.v_n, coarse.C_nr, dt, "free")
    filt = AidedInertial(nav, initial_covariance(initial, noise), noise)
    i = coarse.index
    aided = run_aided(filt, dtheta[i:], dv[i:], t0 + i * dt, [track, *measurements], step_s)
    return InMotionResult(coarse, aided)


class InMotionAligner:
    """In-motion alignment on a track for the navigation engine, fed chunk by chunk: the
    coarse (OBA) stage on the first ``coarse_s``, then the filter aided by the track's
    positions up to ``align_s``; the interface of :class:`rinscal.nav.align.Aligner`
    (:attr:`n_total`, :attr:`done`, :meth:`feed`, then :attr:`nav`, :attr:`gyro_bias`,
    :attr:`accel_bias` and :meth:`result`).

    Parameters
    ----------
    track : GnssTrack
        The reference track (positions at 1 Hz or so) [s, rad, m].
    noise : ImuNoise
        The IMU's noise and bias priors for the filter (SI).
    dt : float [s]
        Sample interval.
    t0 : float [s]
        Start of the first sample fed.
    align_s : float [s]
        Length of the alignment (coarse stage included); free navigation follows.
    coarse_s : float [s]
        Coarse (OBA) window, at most ``align_s``.
    vertical : {"hold", "damped", "free"}
        Vertical channel of the navigation handed over.
    k0 : int
        Samples before the first fed (the navigation counts samples from there).
    """

    def __init__(
        self,
        track: GnssTrack,
        noise: ImuNoise,
        dt: float,
        t0: float,
        align_s: float,
        coarse_s: float = 60.0,
        vertical: str = "hold",
        k0: int = 0,
    ) -> None:
        if not (math.isfinite(align_s) and align_s >= coarse_s > 0):
            raise ConfigError(
                f"in-motion alignment: need align_s >= coarse_s > 0 s, got {align_s}, {coarse_s}"
            )
        self.track, self.noise = track, noise
        self.dt, self.t0, self.coarse_s = float(dt), float(t0), float(coarse_s)
        self.vertical, self.k0 = vertical, int(k0)
        self.n_total = round(align_s / dt)
        self.n_coarse = round(coarse_s / dt)
        self.k = 0
        self._buf: list[tuple[NDArray[np.float64], NDArray[np.float64]]] = []
        self.coarse: CoarseResult | None = None
        self.filt: AidedInertial | None = None
        self.nav: Strapdown | None = None
        self.gyro_bias = np.zeros(3)
        self.accel_bias = np.zeros(3)

    @property
    def done(self) -> bool:
        return self.k >= self.n_total

    def feed(self, dtheta: NDArray[np.float64], dv: NDArray[np.float64]) -> int:
        """Take raw increments [rad], [m/s] (n, 3); return how many the alignment used."""
        m = min(dtheta.shape[0], self.n_total - self.k)
        if m <= 0:
            return 0
        if self.filt is None:
            self._buf.append((dtheta[:m], dv[:m]))
            if self.k + m >= self.n_coarse:
                self._start(np.concatenate([b[0] for b in self._buf]),
                            np.concatenate([b[1] for b in self._buf]))  # fmt: skip
                self._buf = []
        else:
            run_aided(self.filt, dtheta[:m], dv[:m], self.t0 + self.k * self.dt, [self.track])
        self.k += m
        if self.done:
            self._hand_over()
        return m

    def _start(self, dtheta: NDArray[np.float64], dv: NDArray[np.float64]) -> None:
        c = coarse_in_motion(dtheta, dv, self.dt, self.t0, self.track, self.coarse_s)
        initial = InitialSd(
            position_sd=self.track.position_sd,
            velocity_sd=0.5,
            level_sd=math.radians(0.5),
            heading_sd=HEADING_PRIOR_SD,
        )
        nav = Strapdown(c.lat, c.lon, c.alt, c.v_n, c.C_nr, self.dt, "free")
        nav.k = self.k0 + c.index
        self.coarse = c
        self.filt = AidedInertial(nav, initial_covariance(initial, self.noise), self.noise)
        i = c.index
        run_aided(self.filt, dtheta[i:], dv[i:], self.t0 + i * self.dt, [self.track])

    def _hand_over(self) -> None:
        if self.filt is None:
            raise ConfigError("in-motion alignment: ended before its coarse window")
        f = self.filt.nav
        self.nav = Strapdown(f.lat, f.lon, f.alt, f.v_n, f.C_nr, self.dt, self.vertical)  # type: ignore[arg-type]
        self.nav.k = f.k
        self.gyro_bias = self.filt.gyro_bias.copy()
        self.accel_bias = self.filt.accel_bias.copy()

    def result(self) -> AlignResult:
        """The alignment's outcome (the filter's estimates and standard deviations)."""
        assert self.filt is not None and self.coarse is not None and self.nav is not None
        sd = np.sqrt(np.diag(self.filt.P))
        return AlignResult(
            C_nr=self.nav.C_nr,
            gyro_bias=self.gyro_bias.copy(),
            accel_bias=self.accel_bias.copy(),
            attitude_sd=sd[6:9],
            gyro_bias_sd=sd[9:12],
            accel_bias_sd=sd[12:15],
            C_nr_coarse=self.coarse.C_nr,
        )


__all__ = [
    "CoarseResult",
    "InMotionAligner",
    "InMotionResult",
    "coarse_in_motion",
    "navigate_aided",
    "track_velocity",
]
