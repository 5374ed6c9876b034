"""Aiding as measurements: what a navigation filter may be told besides the IMU.

A measurement (the :class:`Measurement` protocol) knows when it is available
(:attr:`Measurement.times`) and, given the INS state at such a time, linearises itself:
the residual, its Jacobian on the error state and the covariance of its noise
(:class:`Linearised`). The navigation core (:mod:`rinscal.nav.gnss_ins`) never asks what a
measurement is, so zero velocity (today's stationary alignment), a known site and a GNSS
track are three implementations of one interface, and more can be added without touching
the filter.

Error state (15, SI, ENU, the conventions of :mod:`rinscal.nav.align`), every error
*INS minus truth*::

    0..2   δr   position error [m] (east, north, up)
    3..5   δv   velocity error [m/s] (ENU)
    6..8   φ    attitude error [rad], C̃_nr = (I − [φ×]) C_nr
    9..11  ε    gyro bias left in the compensated output [rad/s] (r frame)
    12..14 ∇    accelerometer bias left in the compensated output [m/s²] (r frame)

(the bias states are the bias *not yet* removed: the estimate grows by ``x[9:15]`` at each
feedback, as in :class:`rinscal.nav.align.Aligner`).

Residual sign. With the error state defined as INS minus truth, the residual here is the
INS *prediction* minus the measurement, ``y = h(x̂) − z = H δx + v`` (pyins' convention),
i.e. the negative of the innovation ``z − h(x̂)``: the update's estimate ``δx̂ = K y`` is
an error to remove, the sign that :meth:`rinscal.nav.strapdown.Strapdown.correct` takes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rinscal import earth
from rinscal.earth import enu_difference
from rinscal.errors import ConfigError
from rinscal.nav.strapdown import skew

#: Size of the error state.
N_STATES = 15
#: Slices of the error state (see the module docstring).
POS = slice(0, 3)
VEL = slice(3, 6)
ATT = slice(6, 9)
GYRO = slice(9, 12)
ACCEL = slice(12, 15)


@dataclass(frozen=True)
class NavState:
    """The INS solution a measurement is linearised about.

    Attributes
    ----------
    t : float [s]
        Time (the measurement's; the position is extrapolated to it by the velocity).
    lat, lon : float [rad]
        Position.
    alt : float [m]
        Height above the ellipsoid.
    v_n : ndarray, shape (3,) [m/s]
        ENU velocity.
    C_nr : ndarray, shape (3, 3)
        Attitude of the IMU frame ``r``.
    omega_r : ndarray, shape (3,) [rad/s]
        Mean angular rate ω_ir^r over the last step (for a lever arm's velocity).
    """

    t: float
    lat: float
    lon: float
    alt: float
    v_n: NDArray[np.float64]
    C_nr: NDArray[np.float64]
    omega_r: NDArray[np.float64]


@dataclass(frozen=True)
class Linearised:
    """One measurement linearised about the INS solution.

    Attributes
    ----------
    residual : ndarray, shape (m,)
        INS prediction minus measurement ``h(x̂) − z`` (units of the measurement: m, m/s).
    H : ndarray, shape (m, 15)
        Jacobian of the residual on the error state (``residual ≈ H δx + v``).
    R : ndarray, shape (m, m)
        Covariance of the measurement noise ``v`` (units squared).
    """

    residual: NDArray[np.float64]
    H: NDArray[np.float64]
    R: NDArray[np.float64]


@runtime_checkable
class Measurement(Protocol):
    """An aiding source: available at :attr:`times`, linearised by :meth:`linearise`."""

    #: Times at which the measurement is available [s], increasing.
    times: NDArray[np.float64]

    def linearise(self, k: int, state: NavState) -> Linearised | None:
        """Residual, Jacobian and noise of the ``k``-th measurement (at ``times[k]``)
        about the INS solution ``state`` at that time; None to skip it."""
        ...


# --------------------------------------------------------------------------- checks
def _check_times(name: str, t: ArrayLike) -> NDArray[np.float64]:
    tt = np.atleast_1d(np.asarray(t, dtype=float))
    if tt.ndim != 1 or not np.all(np.isfinite(tt)) or np.any(np.diff(tt) <= 0):
        raise ConfigError(f"{name}: times must be finite and strictly increasing")
    return tt


def _check_sd(name: str, sd: float) -> float:
    if not (math.isfinite(sd) and sd > 0):
        raise ConfigError(f"{name}: standard deviation must be > 0, got {sd}")
    return float(sd)


def _rows(block: slice, m: int = 3) -> NDArray[np.float64]:
    """Jacobian rows with the identity on one block of the error state."""
    H = np.zeros((m, N_STATES))
    H[:, block] = np.eye(3)[:m]
    return H


# --------------------------------------------------------------------------- measurements
class ZeroVelocity:
    """The IMU centre is at rest (today's stationary alignment, a zero-velocity update).

    Parameters
    ----------
    times : array_like [s]
        Update times.
    sd : float [m/s]
        Standard deviation of the zero-velocity measurement.
    horizontal : bool
        Only east and north (the vertical channel is held to a reference), as
        :class:`rinscal.nav.align.Aligner` does; False adds up.
    """

    def __init__(self, times: ArrayLike, sd: float, horizontal: bool = True) -> None:
        self.times = _check_times("zero velocity", times)
        self.m = 2 if horizontal else 3
        self._H = _rows(VEL, self.m)
        self._R = np.eye(self.m) * _check_sd("zero velocity", sd) ** 2

    def linearise(self, k: int, state: NavState) -> Linearised:
        return Linearised(np.asarray(state.v_n[: self.m], dtype=float), self._H, self._R)


class KnownPosition:
    """The IMU centre is at a known site (a surveyed point) at the given times.

    Parameters
    ----------
    times : array_like [s]
        Update times.
    lat, lon : float [rad]
        The site.
    alt : float [m]
        Its height above the ellipsoid.
    sd : float [m]
        Standard deviation of each coordinate.
    """

    def __init__(self, times: ArrayLike, lat: float, lon: float, alt: float, sd: float) -> None:
        self.times = _check_times("known position", times)
        self.site = (float(lat), float(lon), float(alt))
        self._H = _rows(POS)
        self._R = np.eye(3) * _check_sd("known position", sd) ** 2

    def linearise(self, k: int, state: NavState) -> Linearised:
        y = enu_difference(state.lat, state.lon, state.alt, *self.site)
        return Linearised(y, self._H, self._R)


class GnssTrack:
    """Positions (and velocities, if given) from a reference track: GNSS, loosely coupled.

    The track gives the antenna's position at ``times``; the antenna sits at the lever arm
    ``lever_arm_r`` from the IMU centre, resolved in the IMU frame ``r`` (zero by default;
    with a turning table the arm rotates with ``r``, so give it only for an IMU fixed to
    the body or an antenna on the table's axis).

    Parameters
    ----------
    times : array_like, shape (m,) [s]
        Fix times (the navigation's clock).
    lat, lon : array_like, shape (m,) [rad]
        Antenna positions.
    alt : array_like, shape (m,) [m]
        Antenna heights above the ellipsoid.
    position_sd : float [m]
        Standard deviation of each position coordinate.
    v_n : array_like, shape (m, 3), optional [m/s]
        Antenna ENU velocities; None: positions only.
    velocity_sd : float [m/s]
        Standard deviation of each velocity component (with ``v_n``).
    lever_arm_r : array_like, shape (3,) [m]
        IMU centre to antenna, in ``r``.
    horizontal : bool
        Use east and north only (the vertical channel held elsewhere); default all three.
    """

    def __init__(
        self,
        times: ArrayLike,
        lat: ArrayLike,
        lon: ArrayLike,
        alt: ArrayLike,
        position_sd: float,
        v_n: ArrayLike | None = None,
        velocity_sd: float = 0.1,
        lever_arm_r: ArrayLike = (0.0, 0.0, 0.0),
        horizontal: bool = False,
    ) -> None:
        self.times = _check_times("GNSS track", times)
        n = self.times.size
        self.lat = np.asarray(lat, dtype=float).reshape(-1)
        self.lon = np.asarray(lon, dtype=float).reshape(-1)
        self.alt = np.asarray(alt, dtype=float).reshape(-1)
        if not (self.lat.size == self.lon.size == self.alt.size == n):
            raise ConfigError("GNSS track: times, lat, lon and alt must have equal length")
        self.v_n = None if v_n is None else np.asarray(v_n, dtype=float).reshape(n, 3)
        self.lever_arm_r = np.asarray(lever_arm_r, dtype=float).reshape(3)
        self.m = 2 if horizontal else 3
        self.position_sd = _check_sd("GNSS track position", position_sd)
        pos_var = self.position_sd**2
        self._var = np.full(self.m, pos_var)
        if self.v_n is not None:
            vel_var = _check_sd("GNSS track velocity", velocity_sd) ** 2
            self._var = np.concatenate([self._var, np.full(self.m, vel_var)])

    def linearise(self, k: int, state: NavState) -> Linearised:
        m = self.m
        C = state.C_nr
        arm_n = C @ self.lever_arm_r
        y_pos = (
            enu_difference(state.lat, state.lon, state.alt, self.lat[k], self.lon[k], self.alt[k])
            + arm_n
        )
        # C̃ l = C l + (C l) × φ: the attitude error moves the predicted antenna
        H_pos = _rows(POS)
        H_pos[:, ATT] = skew(arm_n)
        ys, Hs = [y_pos[:m]], [H_pos[:m]]
        if self.v_n is not None:
            arm_v = C @ np.cross(state.omega_r, self.lever_arm_r)
            H_vel = _rows(VEL)
            H_vel[:, ATT] = skew(arm_v)
            ys.append((state.v_n + arm_v - self.v_n[k])[:m])
            Hs.append(H_vel[:m])
        return Linearised(np.concatenate(ys), np.vstack(Hs), np.diag(self._var))


class BodyHeadingHeld:
    """The parked body does not turn: its heading change over each step is zero, the table
    (IMU frame ``r``) turning about the body's z by the encoder's angle (a zero integrated
    heading rate, ZIHR, against the encoder).

    The body's angular rate relative to ``n`` is ``ω_nb^n = C_nr (ω_ir^r − φ̇ z) − ω_ie^n``
    (``C_br = R_z(φ)``, :func:`rinscal.nav.rotation.C_br`; the transport rate is zero at
    rest), and the heading (clockwise from north) turns at ``−(ω_nb^n)_U``. Over a step of
    ``T`` seconds, with the step's mean compensated rate ``ω̄`` (``NavState.omega_r``) and
    the encoder's change ``Δφ`` over the same samples, the INS predicts the heading change::

        Δψ̂ = −[C_nr (ω̄ T − Δφ z)]_U + Ω sin L · T          (truth: 0)

    With ``C̃_nr = (I − [φ×]) C_nr`` and the bias ``ε`` left in ``ω̄`` the residual is,
    to first order, ``Δψ̂ = −T (C_nr ε)_U + T (φ × w)_U`` with ``w = C_nr (ω̄ − Δφ/T z) ≈
    ω_ie^n`` (the encoder removes the table's own rate), i.e. the same ``−(C ε)_U + Ω cos L
    φ_E`` that drives the heading error in :mod:`rinscal.nav.gnss_ins`. Measured against the
    mean *rate* of the step, not against the heading of the previous epoch, the residual
    involves only the states at the step's end (no delayed state is needed); its noise is
    the angle random walk over the step, ``σ_g² T``, plus the encoder's reading noise twice
    (the two readings that make ``Δφ``). That white noise also drives the heading error in
    the filter's process model; the correlation is left out (it touches ``φ_U``, which the
    measurement does not see). The vertical gyro bias is seen directly, at every step, as
    the table's rate against the encoder.

    Parameters
    ----------
    times : array_like, shape (m,) [s]
        Step ends.
    angle_change : array_like, shape (m,) [rad]
        Encoder change ``Δφ`` over each step (unwrapped).
    duration : array_like, shape (m,) [s]
        Length ``T`` of each step.
    gyro_noise_density : float [rad/√s]
        Angle random walk of the gyros.
    encoder_sd : float [rad]
        Standard deviation of one encoder reading (0: none).
    """

    def __init__(
        self,
        times: ArrayLike,
        angle_change: ArrayLike,
        duration: ArrayLike,
        gyro_noise_density: float,
        encoder_sd: float = 0.0,
    ) -> None:
        self.times = _check_times("body heading held", times)
        m = self.times.size
        self.angle_change = np.asarray(angle_change, dtype=float).reshape(-1)
        self.duration = np.asarray(duration, dtype=float).reshape(-1)
        if self.angle_change.size != m or self.duration.size != m:
            raise ConfigError(
                "body heading held: times, angle_change and duration must have equal length"
            )
        if not (np.all(np.isfinite(self.angle_change)) and np.all(self.duration > 0)):
            raise ConfigError("body heading held: angle_change finite and duration > 0 s")
        g = _check_sd("body heading held: gyro_noise_density", gyro_noise_density)
        if not (math.isfinite(encoder_sd) and encoder_sd >= 0):
            raise ConfigError(f"body heading held: encoder_sd must be >= 0, got {encoder_sd}")
        self._var = g * g * self.duration + 2.0 * float(encoder_sd) ** 2

    def linearise(self, k: int, state: NavState) -> Linearised:
        T = float(self.duration[k])
        C = np.asarray(state.C_nr, dtype=float)
        rel = np.asarray(state.omega_r, dtype=float) * T
        rel[2] -= self.angle_change[k]
        w = C @ rel / T
        dpsi = -w[2] * T + earth.RATE * math.sin(state.lat) * T
        H = np.zeros((1, N_STATES))
        H[0, GYRO] = -T * C[2]
        H[0, 6] = T * w[1]
        H[0, 7] = -T * w[0]
        return Linearised(np.array([dpsi]), H, np.array([[self._var[k]]]))


__all__ = [
    "ACCEL",
    "ATT",
    "GYRO",
    "N_STATES",
    "POS",
    "VEL",
    "BodyHeadingHeld",
    "GnssTrack",
    "KnownPosition",
    "Linearised",
    "Measurement",
    "NavState",
    "ZeroVelocity",
    "enu_difference",
]
