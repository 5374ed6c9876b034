"""The turntable of a single-axis RINS: the rotating IMU frame ``r`` and rotation schedules.

Frames (paper Section 2.1, Eqs. 1-7): the turntable axis is body z. The encoder angle ``φ``
rotates ``r`` about ``z_b`` counter-clockwise (seen from above), so

    C_br(φ) = [[cos φ, −sin φ, 0], [sin φ, cos φ, 0], [0, 0, 1]]        (Eq. 1, C_r^b)

and the IMU measures ``ω_ir^r = C_rb ω_ib^b + φ̇ z`` and ``f^r = C_rb f^b`` (Eqs. 2-3 with
the IMU centre on the axis, so that the rotation adds no specific force). A constant sensor
bias in ``r`` becomes, seen in ``b``, the rotating vector of Eqs. 6-7, whose horizontal part
averages to zero over a rotation cycle (Eqs. 8-9).

A schedule is a piecewise-quadratic encoder angle over one cycle, repeated with a fixed
period and a fixed angle offset per cycle (0 for back-and-forth sequences such as the
four-position one, ±2π for continuous rotation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rinscal import _kernels, units
from rinscal.errors import ConfigError

#: The classical four-position sequence of the paper (Section 2.1) [deg].
FOUR_POSITIONS_DEG = (-135.0, 45.0, 135.0, -45.0)


def C_br(phi: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrix from ``r`` to ``b`` for encoder angle ``phi`` [rad] (Eq. 1).

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    phi = np.asarray(phi, dtype=float)
    c, s = np.cos(phi), np.sin(phi)
    out = np.zeros((*phi.shape, 3, 3))
    out[..., 0, 0] = c
    out[..., 0, 1] = -s
    out[..., 1, 0] = s
    out[..., 1, 1] = c
    out[..., 2, 2] = 1.0
    return out


def _move_segments(
    delta: float, rate: float, accel: float | None
) -> list[tuple[float, float, float, float]]:
    """Segments (duration, c0, c1, c2) of a move by ``delta`` [rad] from angle 0."""
    if delta == 0.0:
        return []
    sgn = 1.0 if delta > 0 else -1.0
    d = abs(delta)
    if accel is None:  # constant-rate move: rate steps at both ends
        return [(d / rate, 0.0, sgn * rate, 0.0)]
    w = rate
    if d < w * w / accel:  # triangular profile
        w = math.sqrt(d * accel)
    ta = w / accel
    tc = d / w - ta
    segs = [(ta, 0.0, 0.0, sgn * 0.5 * accel)]
    phi = 0.5 * accel * ta * ta
    if tc > 1e-12:
        segs.append((tc, sgn * phi, sgn * w, 0.0))
        phi += w * tc
    segs.append((ta, sgn * phi, sgn * w, -sgn * 0.5 * accel))
    return segs


@dataclass(frozen=True)
class RotationSchedule:
    """Encoder angle against time: piecewise-quadratic segments over one repeating cycle.

    Within a cycle, segment ``k`` starts at ``starts[k]`` [s] (cycle time) and has
    ``φ = c0 + c1 τ + c2 τ²`` [rad] with ``τ`` the time since its start. Cycle ``j`` adds
    ``j · offset`` [rad]. Before ``t_start`` [s] the table holds ``coefs[0][0]``.
    Use the constructors :meth:`four_position`, :meth:`continuous` and :meth:`none`.

    Parameters
    ----------
    name : str
        Human-readable description.
    starts : tuple of float [s]
        Segment start times within a cycle; the first is 0.
    coefs : tuple of (float, float, float) [rad, rad/s, rad/s²]
        Polynomial coefficients of each segment.
    period : float [s]
        Cycle length; 0 for a schedule that does not repeat (its last segment lasts forever).
    offset : float [rad]
        Angle added per cycle.
    t_start : float [s]
        Time at which the first cycle starts.
    """

    name: str
    starts: tuple[float, ...]
    coefs: tuple[tuple[float, float, float], ...]
    period: float = 0.0
    offset: float = 0.0
    t_start: float = 0.0

    def __post_init__(self) -> None:
        s = np.asarray(self.starts, dtype=float)
        c = np.asarray(self.coefs, dtype=float)
        if s.ndim != 1 or s.size == 0 or s[0] != 0.0 or np.any(np.diff(s) <= 0):
            raise ConfigError("rotation schedule: starts must begin at 0 and increase")
        if c.shape != (s.size, 3) or not np.all(np.isfinite(c)):
            raise ConfigError("rotation schedule: need one finite (c0, c1, c2) per segment")
        if not (math.isfinite(self.period) and self.period >= 0):
            raise ConfigError(f"rotation schedule: period must be >= 0 s, got {self.period}")
        if self.period > 0 and s[-1] >= self.period:
            raise ConfigError("rotation schedule: a segment starts after the cycle ends")
        if not math.isfinite(self.t_start) or self.t_start < 0:
            raise ConfigError(f"rotation schedule: t_start must be >= 0 s, got {self.t_start}")

    # ------------------------------------------------------------------ constructors
    @classmethod
    def none(cls, angle_deg: float = 0.0) -> RotationSchedule:
        """No rotation: the table holds ``angle_deg`` [deg] for ever."""
        return cls("none", (0.0,), ((angle_deg * units.DEG_TO_RAD, 0.0, 0.0),))

    @classmethod
    def continuous(
        cls, rate_dps: float = 6.0, start_deg: float = 0.0, t_start: float = 0.0
    ) -> RotationSchedule:
        """Continuous rotation at ``rate_dps`` [deg/s] (sign gives the direction)."""
        if not math.isfinite(rate_dps) or rate_dps == 0:
            raise ConfigError(f"continuous rotation: rate_dps must be non-zero, got {rate_dps}")
        w = rate_dps * units.DEG_TO_RAD
        return cls(
            f"continuous {rate_dps:g} deg/s",
            (0.0,),
            ((start_deg * units.DEG_TO_RAD, w, 0.0),),
            period=2 * math.pi / abs(w),
            offset=math.copysign(2 * math.pi, w),
            t_start=t_start,
        )

    @classmethod
    def four_position(
        cls,
        dwell_s: float = 60.0,
        rate_dps: float = 10.0,
        accel_dps2: float | None = 10.0,
        positions_deg: tuple[float, ...] = FOUR_POSITIONS_DEG,
        t_start: float = 0.0,
    ) -> RotationSchedule:
        """The four-position sequence (−135°, 45°, 135°, −45°) with dwell at each position.

        Moves go by the plain differences of consecutive positions, so the sequence turns
        +180°, +90°, −180°, −90° and returns to its start: the rotation direction reverses
        within each cycle and the cable never winds up.

        Parameters
        ----------
        dwell_s : float [s]
            Time at rest at each position (0, or at least 1 ns).
        rate_dps : float [deg/s]
            Cruise rate of a move.
        accel_dps2 : float or None [deg/s²]
            Angular acceleration of a smooth (trapezoidal-rate) move; ``None`` for
            constant-rate moves (the rate steps at both ends).
        positions_deg : tuple of float [deg]
            The positions, visited in order and then back to the first.
        t_start : float [s]
            When the first cycle starts (the table holds the first position before).
        """
        if not (math.isfinite(dwell_s) and dwell_s >= 0):
            raise ConfigError(f"four-position: dwell_s must be >= 0, got {dwell_s}")
        if not (math.isfinite(rate_dps) and rate_dps > 0):
            raise ConfigError(f"four-position: rate_dps must be > 0, got {rate_dps}")
        if accel_dps2 is not None and not (math.isfinite(accel_dps2) and accel_dps2 > 0):
            raise ConfigError(f"four-position: accel_dps2 must be > 0, got {accel_dps2}")
        if len(positions_deg) < 2:
            raise ConfigError("four-position: need at least two positions")
        pos = [p * units.DEG_TO_RAD for p in positions_deg]
        rate = rate_dps * units.DEG_TO_RAD
        accel = None if accel_dps2 is None else accel_dps2 * units.DEG_TO_RAD
        starts: list[float] = []
        coefs: list[tuple[float, float, float]] = []
        t = 0.0
        for i, p in enumerate(pos):
            nxt = pos[(i + 1) % len(pos)]
            if dwell_s > 1e-9:  # dwells shorter than 1 ns are ignored
                starts.append(t)
                coefs.append((p, 0.0, 0.0))
                t += dwell_s
            for dur, c0, c1, c2 in _move_segments(nxt - p, rate, accel):
                starts.append(t)
                coefs.append((p + c0, c1, c2))
                t += dur
        if not starts:
            raise ConfigError("four-position: the positions are all equal and dwell_s is 0")
        label = "smooth" if accel is not None else "constant-rate"
        return cls(
            f"four-position dwell {dwell_s:g} s, {rate_dps:g} deg/s, {label}",
            tuple(starts),
            tuple(coefs),
            period=t,
            offset=0.0,
            t_start=t_start,
        )

    # ------------------------------------------------------------------ evaluation
    def arrays(self) -> tuple[NDArray[np.float64], NDArray[np.float64], float, float, float]:
        """The schedule as arrays for the numba kernels."""
        return (
            np.asarray(self.starts, dtype=float),
            np.asarray(self.coefs, dtype=float).reshape(-1, 3),
            float(self.period),
            float(self.offset),
            float(self.t_start),
        )

    def evaluate(self, t: ArrayLike) -> tuple[NDArray, NDArray, NDArray]:
        """Encoder angle [rad], rate [rad/s] and angular acceleration [rad/s²] at ``t`` [s]."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        starts, coefs, period, offset, t_start = self.arrays()
        phi = np.empty_like(t)
        rate = np.empty_like(t)
        acc = np.empty_like(t)
        _kernels.schedule_eval_many(t, starts, coefs, period, offset, t_start, phi, rate, acc)
        return phi, rate, acc

    def angle(self, t: ArrayLike) -> NDArray[np.float64]:
        """Encoder angle φ(t) [rad]."""
        return self.evaluate(t)[0]

    def rate(self, t: ArrayLike) -> NDArray[np.float64]:
        """Encoder rate φ̇(t), i.e. ω_br^r z-component [rad/s]."""
        return self.evaluate(t)[1]

    def acceleration(self, t: ArrayLike) -> NDArray[np.float64]:
        """Encoder angular acceleration φ̈(t) [rad/s²]."""
        return self.evaluate(t)[2]

    def breakpoints(self, t0: float, t1: float) -> NDArray[np.float64]:
        """Times in ``(t0, t1)`` [s] where the angle's polynomial changes."""
        starts, _, period, _, t_start = self.arrays()
        out = []
        t = t0
        while True:
            t = _kernels.schedule_next_break(t, starts, period, t_start)
            if t >= t1:
                break
            out.append(t)
        return np.asarray(out)


def schedule_from_name(name: str, **kwargs: float) -> RotationSchedule:
    """Build a schedule by name: ``four-position``, ``continuous`` or ``none``."""
    if name == "four-position":
        return RotationSchedule.four_position(**kwargs)  # type: ignore[arg-type]
    if name == "continuous":
        return RotationSchedule.continuous(**kwargs)
    if name == "none":
        return RotationSchedule.none(**kwargs)
    raise ConfigError(f"rotation: unknown schedule {name!r}; use four-position, continuous or none")


__all__ = ["FOUR_POSITIONS_DEG", "C_br", "RotationSchedule", "schedule_from_name"]
