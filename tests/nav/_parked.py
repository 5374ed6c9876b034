"""Parked cold starts on a static base, made independently of the estimator: the ideal
IMU on a four-position table (:class:`rinscal.sim.ideal_imu.ImuSynthesizer`) plus a known
bias series per channel (turn-on offset and an exponential warm-up) and white noise."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from rinscal.nav.rotation import RotationSchedule
from rinscal.schema import NavSamples
from rinscal.sim.ideal_imu import ImuSynthesizer
from rinscal.sim.trajectory import StaticMotion

LAT_DEG, LON_DEG, ALT_M = 45.0, 10.0, 100.0
DPH = math.pi / 180 / 3600
UG = 9.80665e-6
#: white noise of the simulated unit: 0.001 °/√h, 10 µg/√Hz
GYRO_DENSITY = 0.001 * math.pi / 180 / 60
ACCEL_DENSITY = 10 * UG


@dataclass(frozen=True)
class Parked:
    """A parked start: offsets (6,), warm-up amplitudes (6,) and time constant [s]."""

    heading_deg: float
    pitch_deg: float
    roll_deg: float
    offset: np.ndarray
    warm: np.ndarray
    tau_s: float

    def bias(self, t: np.ndarray) -> np.ndarray:
        """True bias (m, 6) [rad/s, m/s²] at times ``t`` [s]."""
        return self.offset + self.warm * (1.0 - np.exp(-np.asarray(t)[:, None] / self.tau_s))


def parked(seed: int, turn_on: np.ndarray, warm_size: np.ndarray, tau_s: float) -> Parked:
    rng = np.random.default_rng(seed)
    return Parked(
        heading_deg=float(rng.uniform(-180, 180)),
        pitch_deg=float(rng.normal(0, 0.3)),
        roll_deg=float(rng.normal(0, 0.3)),
        offset=rng.normal(0, turn_on),
        warm=warm_size * rng.choice([-1.0, 1.0], 6) * rng.uniform(0.5, 1.0, 6),
        tau_s=tau_s,
    )


def recording(
    p: Parked, duration_s: float, rate_hz: float, seed: int, chunk_s: float = 600.0
) -> Iterator[NavSamples]:
    """The start's NavSamples pieces (SI increments in r, encoder, temperatures)."""
    rng = np.random.default_rng(seed + 1000)
    motion = StaticMotion(LAT_DEG, LON_DEG, ALT_M, p.heading_deg, p.pitch_deg, p.roll_deg)
    syn = ImuSynthesizer(motion, RotationSchedule.four_position(), rate_hz)
    dt = 1.0 / rate_hz
    sig = np.array([GYRO_DENSITY] * 3 + [ACCEL_DENSITY] * 3) * math.sqrt(dt)
    for ch in syn.chunks(duration_s, chunk_s):
        n = ch.t.size
        b = p.bias(ch.t - 0.5 * dt) * dt + rng.normal(0.0, 1.0, (n, 6)) * sig
        temp = 20.0 + 15.0 * (1.0 - np.exp(-ch.t / p.tau_s))
        yield NavSamples(
            t=ch.t,
            dt=np.full(n, dt),
            dtheta=ch.dtheta + b[:, :3],
            dv=ch.dv + b[:, 3:],
            first_row=ch.k0 + 1,
            table=ch.encoder,
            temps=np.repeat(temp[:, None], 6, axis=1),
            temp_out=temp - 2.0,
        )
