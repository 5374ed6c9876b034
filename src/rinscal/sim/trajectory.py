"""Carrier (body frame ``b``) trajectories: quasi-static, swinging base, land vehicle.

A trajectory gives, at any times, the body's ENU velocity and its time derivative and the
body attitude (heading, pitch, roll, see :func:`rinscal.earth.C_nb_from_euler`) with
its rates. Position is not part of it: :mod:`rinscal.sim.ideal_imu` integrates the velocity
exactly, chunk by chunk, from the trajectory's origin.

All motions are analytic (sinusoids, and smooth steps ``Δ·(u − sin 2πu / 2π)`` whose first
and second derivatives vanish at both ends), so the ideal IMU built from them is exact to
quadrature precision.

Table 9 of the paper (the turntable's quasi-static and swing conditions) is garbled in our
copy. We read it as: quasi-static = the turntable held at heading 45°, pitch 0°, roll 0°;
swing = heading, pitch and roll oscillating with amplitudes 2°, 2° and 8° (the "2, 2, 8"
column) and periods 3 s, 3 s and 5 s (the "3, 3, 5" column, read as periods because 3-5 Hz
oscillations of several degrees would mean rates of 100-250 °/s, far from a swing test).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rinscal import _kernels, units
from rinscal.errors import ConfigError
from rinscal.nav.attitude import C_nb_from_euler, euler_from_C_nb

#: Default site: Nanjing (the paper's lab), as in the navigation-grade IMU preset.
DEFAULT_LAT_DEG = 32.06
DEFAULT_LON_DEG = 118.78
DEFAULT_ALT_M = 10.0

#: Our reading of Table 9: quasi-static heading [deg].
QUASI_STATIC_HEADING_DEG = 45.0
#: Our reading of Table 9: swing amplitudes (heading, pitch, roll) [deg].
SWING_AMPLITUDES_DEG = (2.0, 2.0, 8.0)
#: Our reading of Table 9: swing periods (heading, pitch, roll) [s].
SWING_PERIODS_S = (3.0, 3.0, 5.0)


@dataclass(frozen=True)
class Kinematics:
    """Body motion at a set of times (all arrays share the leading shape of ``t``).

    Attributes
    ----------
    v_n : ndarray, shape (..., 3) [m/s]
        ENU velocity.
    a_n : ndarray, shape (..., 3) [m/s²]
        Time derivative of the ENU velocity components.
    euler : ndarray, shape (..., 3) [rad]
        Heading (clockwise from north), pitch, roll.
    euler_rate : ndarray, shape (..., 3) [rad/s]
        Their time derivatives.
    """

    v_n: NDArray[np.float64]
    a_n: NDArray[np.float64]
    euler: NDArray[np.float64]
    euler_rate: NDArray[np.float64]


class Trajectory(Protocol):
    """What :mod:`rinscal.sim.ideal_imu` needs from a carrier motion."""

    #: Start position: latitude [rad], longitude [rad], altitude [m].
    lat0: float
    lon0: float
    alt0: float
    #: True if the body never moves (constant attitude, zero velocity).
    is_static: bool
    #: The body is at rest (zero velocity, IMU centre fixed) until this time [s].
    stationary_until: float

    def kinematics(self, t: NDArray[np.float64]) -> Kinematics:
        """Body motion at times ``t`` [s]."""
        ...


# --------------------------------------------------------------------------- attitude helpers
# C_nb_from_euler and euler_from_C_nb live in rinscal.nav.attitude (navigation uses them too)
def body_rate_from_euler(euler: ArrayLike, euler_rate: ArrayLike) -> NDArray[np.float64]:
    """Angular rate of ``b`` relative to ``n`` resolved in ``b``, ω_nb^b [rad/s].

    For ``C_nb = Rz(−ψ) Rx(θ) Ry(γ)``:
    ``ω_nb^b = (θ̇ cos γ + ψ̇ sin γ cos θ, γ̇ − ψ̇ sin θ, θ̇ sin γ − ψ̇ cos γ cos θ)``.
    """
    e = np.asarray(euler, dtype=float)
    r = np.asarray(euler_rate, dtype=float)
    cp, sp = np.cos(e[..., 1]), np.sin(e[..., 1])
    cr, sr = np.cos(e[..., 2]), np.sin(e[..., 2])
    hd, pd, rd = r[..., 0], r[..., 1], r[..., 2]
    return np.stack([pd * cr + hd * sr * cp, rd - hd * sp, pd * sr - hd * cr * cp], axis=-1)


# --------------------------------------------------------------------------- motions
class _Site:
    """Start position (:class:`Trajectory` ``lat0``, ``lon0``, ``alt0``) of the motions below.

    The motions are dataclasses with the fields ``lat_deg``, ``lon_deg`` [deg] and
    ``alt_m`` [m]; this base class only converts them.
    """

    lat_deg: float
    lon_deg: float
    alt_m: float

    @property
    def lat0(self) -> float:
        return self.lat_deg * units.DEG_TO_RAD

    @property
    def lon0(self) -> float:
        return self.lon_deg * units.DEG_TO_RAD

    @property
    def alt0(self) -> float:
        return float(self.alt_m)


# --------------------------------------------------------------------------- static and swing
@dataclass(frozen=True)
class StaticMotion(_Site):
    """A body at rest on the Earth with a fixed attitude (the quasi-static turntable).

    Parameters
    ----------
    lat_deg, lon_deg : float [deg]
        Site.
    alt_m : float [m]
        Height above the ellipsoid.
    heading_deg, pitch_deg, roll_deg : float [deg]
        Attitude of the body (turntable) frame.
    """

    lat_deg: float = DEFAULT_LAT_DEG
    lon_deg: float = DEFAULT_LON_DEG
    alt_m: float = DEFAULT_ALT_M
    heading_deg: float = QUASI_STATIC_HEADING_DEG
    pitch_deg: float = 0.0
    roll_deg: float = 0.0

    is_static = True
    stationary_until = math.inf

    def __post_init__(self) -> None:
        if not abs(self.lat_deg) <= 89.0:
            raise ConfigError(f"static motion: lat_deg must be within ±89°, got {self.lat_deg}")

    @property
    def euler0(self) -> NDArray[np.float64]:
        """Heading, pitch, roll [rad]."""
        return np.array([self.heading_deg, self.pitch_deg, self.roll_deg]) * units.DEG_TO_RAD

    def kinematics(self, t: NDArray[np.float64]) -> Kinematics:
        shape = (*np.shape(t), 3)
        z = np.zeros(shape)
        return Kinematics(z, z, np.broadcast_to(self.euler0, shape).copy(), z)


@dataclass(frozen=True)
class SwingMotion(_Site):
    """A swinging base: heading, pitch and roll oscillate about a mean attitude.

    The IMU centre stays fixed (the turntable's axes cross at it), so the velocity is zero.
    Defaults are our reading of Table 9 (see the module docstring).

    Parameters
    ----------
    lat_deg, lon_deg, alt_m
        Site [deg, deg, m].
    mean_deg : tuple of 3 float [deg]
        Mean heading, pitch, roll.
    amplitude_deg : tuple of 3 float [deg]
        Oscillation amplitudes of heading, pitch, roll.
    period_s : tuple of 3 float [s]
        Oscillation periods.
    phase_deg : tuple of 3 float [deg]
        Phases at t = 0.
    """

    lat_deg: float = DEFAULT_LAT_DEG
    lon_deg: float = DEFAULT_LON_DEG
    alt_m: float = DEFAULT_ALT_M
    mean_deg: tuple[float, float, float] = (QUASI_STATIC_HEADING_DEG, 0.0, 0.0)
    amplitude_deg: tuple[float, float, float] = SWING_AMPLITUDES_DEG
    period_s: tuple[float, float, float] = SWING_PERIODS_S
    phase_deg: tuple[float, float, float] = (0.0, 60.0, 120.0)

    is_static = False
    stationary_until = math.inf

    def __post_init__(self) -> None:
        if not abs(self.lat_deg) <= 89.0:
            raise ConfigError(f"swing motion: lat_deg must be within ±89°, got {self.lat_deg}")
        if any(not (math.isfinite(p) and p > 0) for p in self.period_s):
            raise ConfigError(f"swing motion: period_s must be > 0, got {self.period_s}")
        if abs(self.mean_deg[1]) + abs(self.amplitude_deg[1]) >= 80.0:
            raise ConfigError("swing motion: pitch would come within 10° of the vertical")

    def kinematics(self, t: NDArray[np.float64]) -> Kinematics:
        t = np.asarray(t, dtype=float)
        d2r = units.DEG_TO_RAD
        euler = np.empty((*t.shape, 3))
        rate = np.empty((*t.shape, 3))
        for k in range(3):
            w = 2 * math.pi / self.period_s[k]
            arg = w * t + self.phase_deg[k] * d2r
            a = self.amplitude_deg[k] * d2r
            euler[..., k] = self.mean_deg[k] * d2r + a * np.sin(arg)
            rate[..., k] = a * w * np.cos(arg)
        z = np.zeros((*t.shape, 3))
        return Kinematics(z, z, euler, rate)


# --------------------------------------------------------------------------- smooth steps
@dataclass(frozen=True)
class StepChannel:
    """A scalar that changes by smooth steps: ``x(t) = x0 + Σ Δ_k S((t − t_k)/D_k)``.

    ``S(u) = u − sin(2πu)/(2π)`` on [0, 1]; its first two derivatives vanish at both ends.
    Steps of one channel must not overlap.
    """

    x0: float
    starts: tuple[float, ...] = ()
    durations: tuple[float, ...] = ()
    deltas: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        s = np.asarray(self.starts, dtype=float)
        d = np.asarray(self.durations, dtype=float)
        if not (s.shape == d.shape == np.shape(self.deltas)):
            raise ConfigError("step channel: starts, durations, deltas must have equal length")
        if np.any(d <= 0) or np.any(s[1:] < s[:-1] + d[:-1] - 1e-9):
            raise ConfigError("step channel: steps must have positive durations and not overlap")

    def table(self) -> NDArray[np.float64]:
        """The steps as an (m, 4) array for the numba kernels: start [s], duration [s], Δ,
        and the sum of the Δ before each step."""
        dl = np.asarray(self.deltas, dtype=float)
        out = np.empty((dl.size, 4))
        out[:, 0] = self.starts
        out[:, 1] = self.durations
        out[:, 2] = dl
        out[:, 3] = np.concatenate([[0.0], np.cumsum(dl)])[:-1]
        return out

    def evaluate(self, t: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
        """Value, first and second derivative at ``t`` [s] (units of ``x0``, per s, per s²)."""
        t = np.asarray(t, dtype=float)
        tf = np.ascontiguousarray(t).reshape(-1)
        x = np.empty(tf.shape)
        xd = np.empty(tf.shape)
        xdd = np.empty(tf.shape)
        _kernels.step_channel_eval(tf, float(self.x0), self.table(), x, xd, xdd)
        return x.reshape(t.shape), xd.reshape(t.shape), xdd.reshape(t.shape)


@dataclass(frozen=True)
class VehicleMotion(_Site):
    """A land vehicle: speed, heading and road grade change by smooth steps.

    The body y axis points along the velocity (no side slip), pitch equals the road grade
    angle and roll is zero, so ``v_n = s (cos θ sin ψ, cos θ cos ψ, sin θ)``.

    Parameters
    ----------
    lat_deg, lon_deg, alt_m
        Start position [deg, deg, m].
    speed, heading, grade : StepChannel
        Speed [m/s], heading [rad] and grade angle [rad] against time.
    duration_s : float [s]
        Length of the route (the vehicle stands still after it).
    stationary_until : float [s]
        The vehicle stands still before this time (alignment).
    """

    lat_deg: float
    lon_deg: float
    alt_m: float
    speed: StepChannel
    heading: StepChannel
    grade: StepChannel
    duration_s: float
    stationary_until: float = 0.0

    is_static = False

    def kinematics(self, t: NDArray[np.float64]) -> Kinematics:
        t = np.asarray(t, dtype=float)
        tf = np.ascontiguousarray(t).reshape(-1)
        shape = (*t.shape, 3)
        v, a, euler, rate = (np.empty((tf.size, 3)) for _ in range(4))
        _kernels.vehicle_kinematics(
            tf,
            float(self.speed.x0),
            self.speed.table(),
            float(self.heading.x0),
            self.heading.table(),
            float(self.grade.x0),
            self.grade.table(),
            v,
            a,
            euler,
            rate,
        )
        return Kinematics(
            v.reshape(shape), a.reshape(shape), euler.reshape(shape), rate.reshape(shape)
        )


@dataclass
class _RouteBuilder:
    speed: list[tuple[float, float, float]] = field(default_factory=list)
    heading: list[tuple[float, float, float]] = field(default_factory=list)
    grade: list[tuple[float, float, float]] = field(default_factory=list)
    t: float = 0.0
    v: float = 0.0

    def go(self, dur: float) -> None:
        self.t += dur

    def speed_to(self, v: float, dur: float) -> None:
        self.speed.append((self.t, dur, v - self.v))
        self.v = v
        self.t += dur

    def turn(self, deg: float, dur: float) -> None:
        self.heading.append((self.t, dur, deg * units.DEG_TO_RAD))
        self.t += dur

    def hill(self, deg: float, ramp: float, hold: float) -> None:
        self.grade.append((self.t, ramp, deg * units.DEG_TO_RAD))
        self.t += ramp + hold
        self.grade.append((self.t, ramp, -deg * units.DEG_TO_RAD))
        self.t += ramp

    @staticmethod
    def channel(x0: float, steps: list[tuple[float, float, float]]) -> StepChannel:
        return StepChannel(
            x0, tuple(s[0] for s in steps), tuple(s[1] for s in steps), tuple(s[2] for s in steps)
        )


def vehicle_route(
    duration_s: float = 1.9 * 3600.0,
    stationary_s: float = 600.0,
    lat_deg: float = DEFAULT_LAT_DEG,
    lon_deg: float = DEFAULT_LON_DEG,
    alt_m: float = DEFAULT_ALT_M,
    heading_deg: float = 30.0,
) -> VehicleMotion:
    """The land-vehicle route of Section 5.2.2: uphill, downhill, turns, speed changes.

    A deterministic 15-minute pattern (urban and rural driving: stops, accelerations to
    10-22 m/s, ±90° turns, 4° up- and down-hill grades, a U-turn) is repeated, each repetition
    turning the other way round, until ``duration_s`` of driving after ``stationary_s`` of
    standing still for the alignment; the vehicle then stops.

    Parameters
    ----------
    duration_s : float [s]
        Driving time (the paper's route lasts 1.9 h).
    stationary_s : float [s]
        Standing still before driving (the alignment).
    lat_deg, lon_deg, alt_m : float [deg, deg, m]
        Start position.
    heading_deg : float [deg]
        Initial heading.

    Returns
    -------
    VehicleMotion
    """
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise ConfigError(f"vehicle route: duration_s must be > 0, got {duration_s}")
    if not (math.isfinite(stationary_s) and stationary_s >= 0):
        raise ConfigError(f"vehicle route: stationary_s must be >= 0, got {stationary_s}")
    b = _RouteBuilder(t=stationary_s)
    end = stationary_s + duration_s - 40.0  # keep time to stop
    rep = 0
    while b.t < end:
        sgn = 1.0 if rep % 2 == 0 else -1.0
        pattern: list[tuple[str, tuple[float, ...]]] = [
            ("speed_to", (12.0, 20.0)),
            ("go", (60.0,)),
            ("hill", (4.0, 8.0, 50.0)),  # uphill
            ("go", (30.0,)),
            ("turn", (90.0 * sgn, 12.0)),
            ("speed_to", (20.0, 15.0)),
            ("go", (120.0,)),
            ("hill", (-4.0, 8.0, 45.0)),  # downhill
            ("go", (40.0,)),
            ("speed_to", (8.0, 12.0)),
            ("turn", (-90.0 * sgn, 10.0)),
            ("speed_to", (15.0, 10.0)),
            ("go", (60.0,)),
            ("turn", (45.0 * sgn, 8.0)),
            ("speed_to", (22.0, 15.0)),
            ("go", (90.0,)),
            ("speed_to", (0.0, 18.0)),  # traffic light
            ("go", (25.0,)),
            ("speed_to", (10.0, 12.0)),
            ("turn", (180.0 * sgn, 25.0)),  # U-turn
            ("speed_to", (18.0, 12.0)),
            ("hill", (3.0, 8.0, 40.0)),
            ("turn", (-45.0 * sgn, 8.0)),
            ("go", (60.0,)),
        ]
        for name, args in pattern:
            if b.t >= end:
                break
            getattr(b, name)(*args)
        rep += 1
    if b.v != 0.0:
        b.speed_to(0.0, 30.0)
    total = max(b.t, stationary_s + duration_s)
    return VehicleMotion(
        lat_deg=lat_deg,
        lon_deg=lon_deg,
        alt_m=alt_m,
        speed=b.channel(0.0, b.speed),
        heading=b.channel(heading_deg * units.DEG_TO_RAD, b.heading),
        grade=b.channel(0.0, b.grade),
        duration_s=total,
        stationary_until=stationary_s,
    )


__all__ = [
    "QUASI_STATIC_HEADING_DEG",
    "SWING_AMPLITUDES_DEG",
    "SWING_PERIODS_S",
    "C_nb_from_euler",
    "Kinematics",
    "StaticMotion",
    "StepChannel",
    "SwingMotion",
    "Trajectory",
    "VehicleMotion",
    "body_rate_from_euler",
    "euler_from_C_nb",
    "vehicle_route",
]
