"""A disturbed start: people about a parked carrier for its first minutes.

A real recording of a parked vehicle starts with people getting in and out, leaning on it
and closing doors: the body sways on its suspension (angular oscillations of a few
arc-minutes at 1-3 Hz, its centre moving a millimetre or so) in bursts, and every time
somebody shifts their weight the vehicle settles at a slightly different tilt (steps of tens
of arc-seconds to a few arc-minutes, its heading by a few arc-seconds). Then the people are
gone and the carrier stands still at its last tilt.

:class:`DisturbedStart` is that motion as a :class:`rinscal.sim.trajectory.Trajectory`:
analytic (sinusoids under ``sin⁴`` envelopes whose first two derivatives vanish at both ends
of a burst, and the smooth steps of :class:`rinscal.sim.trajectory.StepChannel`), so the
ideal IMU built from it, the truth and the navigation errors stay exact. The gyros see it
plainly (per-second mean rates of a few hundred °/h during a burst against the Earth rate's
15 °/h); the accelerometers see the tilt steps (1′ of tilt is 290 µg) and the sway's
acceleration.

Its mean position never moves (the sway is millimetres about the parking place), so it counts
as stationary for the alignment (``stationary_until`` is infinite): aligning on the
disturbance is allowed, and as poor as on a real one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rinscal import units
from rinscal.errors import ConfigError
from rinscal.sim.trajectory import Kinematics, StaticMotion, StepChannel

__all__ = ["DisturbedStart"]

_ARCMIN = units.DEG_TO_RAD / 60.0
_ARCSEC = units.ARCSEC_TO_RAD


@dataclass(frozen=True)
class DisturbedStart:
    """A parked carrier (a static attitude) disturbed by people for ``end_s`` seconds.

    Parameters
    ----------
    base : StaticMotion
        The site and the attitude the carrier is parked at.
    end_s : float [s]
        The disturbance is over by then (every burst and step has ended).
    burst_start_s, burst_length_s : tuple of float [s]
        Sway bursts, in time order, not overlapping.
    burst_freq_hz : tuple of float [Hz]
        Frequency of each burst's sway.
    burst_phase : tuple of float [rad]
        Its phase at t = 0.
    burst_angle : tuple of (float, float, float) [rad]
        Amplitudes of heading, pitch and roll of each burst.
    burst_shift : tuple of (float, float, float) [m]
        Amplitudes of the centre's east, north, up motion of each burst.
    heading, pitch, roll : StepChannel
        Tilt (and heading) steps [rad] added to the base attitude; they stay.
    """

    base: StaticMotion
    end_s: float
    burst_start_s: tuple[float, ...]
    burst_length_s: tuple[float, ...]
    burst_freq_hz: tuple[float, ...]
    burst_phase: tuple[float, ...]
    burst_angle: tuple[tuple[float, float, float], ...]
    burst_shift: tuple[tuple[float, float, float], ...]
    heading: StepChannel
    pitch: StepChannel
    roll: StepChannel

    is_static = False
    stationary_until = math.inf

    def __post_init__(self) -> None:
        if not (math.isfinite(self.end_s) and self.end_s > 0):
            raise ConfigError(f"disturbed start: end_s must be > 0 s, got {self.end_s}")
        n = len(self.burst_start_s)
        lens = {
            len(x)
            for x in (
                self.burst_length_s,
                self.burst_freq_hz,
                self.burst_phase,
                self.burst_angle,
                self.burst_shift,
            )
        }
        if lens - {n}:
            raise ConfigError(
                "disturbed start: every burst needs a length, frequency, phase, angle, shift"
            )
        s = np.asarray(self.burst_start_s, dtype=float)
        d = np.asarray(self.burst_length_s, dtype=float)
        if np.any(d <= 0) or np.any(s[1:] < s[:-1] + d[:-1]) or (n and s[-1] + d[-1] > self.end_s):
            raise ConfigError(
                "disturbed start: bursts must have positive lengths, keep their order, not "
                f"overlap and end by end_s = {self.end_s} s"
            )

    # the Trajectory protocol
    @property
    def lat0(self) -> float:
        return self.base.lat0

    @property
    def lon0(self) -> float:
        return self.base.lon0

    @property
    def alt0(self) -> float:
        return self.base.alt0

    @classmethod
    def draw(
        cls,
        base: StaticMotion,
        end_s: float,
        seed: int = 0,
        sway_arcmin: tuple[float, float] = (2.0, 6.0),
        sway_hz: tuple[float, float] = (1.0, 3.0),
        shift_mm: tuple[float, float] = (0.3, 1.5),
        step_arcsec: tuple[float, float] = (20.0, 180.0),
        step_every_s: float = 45.0,
    ) -> DisturbedStart:
        """A disturbance drawn at random (reproducibly from ``seed``).

        Bursts of sway of 5-40 s with quiet gaps of 2-20 s fill ``[5 s, end_s − 5 s]``;
        each burst sways pitch and roll with amplitudes drawn from ``sway_arcmin`` [′]
        (heading a third of it) at one frequency from ``sway_hz`` [Hz], its centre by
        ``shift_mm`` [mm]. Tilt steps of pitch and roll (sizes from ``step_arcsec`` [″],
        random sign, 0.5-2 s long; heading a tenth) come every ``step_every_s`` [s] on
        average.
        """
        if not (math.isfinite(end_s) and end_s > 10.0):
            raise ConfigError(f"disturbed start: needs more than 10 s, got {end_s} s")
        rng = np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(0x5747,)))
        starts, lengths, freqs, phases, angles, shifts = [], [], [], [], [], []
        t = 5.0
        stop = end_s - 5.0
        while True:
            t += float(rng.uniform(0.0, 8.0))
            length = float(rng.uniform(5.0, 40.0))
            if t + length > stop:
                length = stop - t
                if length < 3.0:
                    break
            amp = rng.uniform(*sway_arcmin, size=2) * _ARCMIN
            angles.append((float(amp.mean() / 3.0), float(amp[0]), float(amp[1])))
            shift = rng.uniform(*shift_mm, size=3) * 1e-3
            shifts.append((float(shift[0]), float(shift[1]), float(shift[2])))
            starts.append(t)
            lengths.append(length)
            freqs.append(float(rng.uniform(*sway_hz)))
            phases.append(float(rng.uniform(0.0, 2 * math.pi)))
            t += length + float(rng.uniform(2.0, 20.0))
        steps: dict[str, tuple[list[float], list[float], list[float]]] = {}
        for name, scale in (("heading", 0.1), ("pitch", 1.0), ("roll", 1.0)):
            st: list[float] = []
            du: list[float] = []
            de: list[float] = []
            t = float(rng.exponential(step_every_s))
            while True:
                dur = float(rng.uniform(0.5, 2.0))
                if t + dur > stop:
                    break
                size = float(rng.uniform(*step_arcsec)) * scale * _ARCSEC
                st.append(t)
                du.append(dur)
                de.append(size if rng.random() < 0.5 else -size)
                t += dur + float(rng.exponential(step_every_s))
            steps[name] = (st, du, de)
        return cls(
            base=base,
            end_s=float(end_s),
            burst_start_s=tuple(starts),
            burst_length_s=tuple(lengths),
            burst_freq_hz=tuple(freqs),
            burst_phase=tuple(phases),
            burst_angle=tuple(angles),  # type: ignore[arg-type]
            burst_shift=tuple(shifts),  # type: ignore[arg-type]
            **{
                k: StepChannel(0.0, tuple(v[0]), tuple(v[1]), tuple(v[2])) for k, v in steps.items()
            },
        )

    def kinematics(self, t: NDArray[np.float64]) -> Kinematics:
        t = np.asarray(t, dtype=float)
        shape = (*t.shape, 3)
        euler = np.broadcast_to(self.base.euler0, shape).copy()
        rate = np.zeros(shape)
        v = np.zeros(shape)
        a = np.zeros(shape)
        for k, ch in enumerate((self.heading, self.pitch, self.roll)):
            if ch.starts:
                x, xd, _ = ch.evaluate(t)
                euler[..., k] += x
                rate[..., k] += xd
        if self.burst_start_s:
            start = np.asarray(self.burst_start_s)
            length = np.asarray(self.burst_length_s)
            b = np.clip(np.searchsorted(start, t, side="right") - 1, 0, start.size - 1)
            u = (t - start[b]) / length[b]
            on = (u > 0.0) & (u < 1.0)
            if np.any(on):
                tt, bb, uu = t[on], b[on], u[on]
                dd = length[bb]
                s, c = np.sin(np.pi * uu), np.cos(np.pi * uu)
                env = s**4
                env1 = 4.0 * np.pi / dd * s**3 * c
                env2 = (np.pi / dd) ** 2 * (12.0 * s**2 * c**2 - 4.0 * s**4)
                w = 2.0 * np.pi * np.asarray(self.burst_freq_hz)[bb]
                arg = w * tt + np.asarray(self.burst_phase)[bb]
                sn, cs = np.sin(arg), np.cos(arg)
                # x = E·sin, x' = E'·sin + E·w·cos, x'' = E''·sin + 2E'·w·cos − E·w²·sin
                x0 = env * sn
                x1 = env1 * sn + env * w * cs
                x2 = env2 * sn + 2.0 * env1 * w * cs - env * w * w * sn
                ang = np.asarray(self.burst_angle)[bb]
                sh = np.asarray(self.burst_shift)[bb]
                euler[on] += ang * x0[:, None]
                rate[on] += ang * x1[:, None]
                v[on] = sh * x1[:, None]
                a[on] = sh * x2[:, None]
        return Kinematics(v, a, euler, rate)

    def summary(self) -> dict[str, Any]:
        """What the disturbance was, for a summary or a recording's metadata."""
        tilt = [float(sum(ch.deltas)) / _ARCSEC for ch in (self.heading, self.pitch, self.roll)]
        ang = np.asarray(self.burst_angle).reshape(-1, 3)
        return {
            "start_s": 0.0,
            "end_s": self.end_s,
            "sway_bursts": len(self.burst_start_s),
            "sway_max_arcmin": float(ang.max() / _ARCMIN) if ang.size else 0.0,
            "tilt_steps": sum(len(ch.deltas) for ch in (self.heading, self.pitch, self.roll)),
            "net_steps_arcsec": {"heading": tilt[0], "pitch": tilt[1], "roll": tilt[2]},
        }
