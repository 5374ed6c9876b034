"""A drive for the aiding tests: the ``paper`` IMU on a car that never stops, and its
GNSS track (1 Hz, white noise drawn here), simulated once per call.

The car starts at 10 m/s (no stop anywhere), then every two minutes speeds up, turns
right, slows, turns left, climbs, turns right and descends; its initial heading is the
caller's and is never given to the navigation. The IMU is strapped down (or on a
turntable when a schedule is given), its errors those of the ``paper`` preset's plant
(thermal bias of a unit in a cabin at 20 °C, scale factor, misalignment, turn-on offsets,
noise), switched on :data:`WARM_S` before the record starts unless told otherwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rinscal import earth
from rinscal.nav.aiding import GnssTrack
from rinscal.nav.gnss_ins import ImuNoise
from rinscal.nav.rotation import C_br, RotationSchedule
from rinscal.sim.config import ImuConfig, load_imu
from rinscal.sim.field import ChamberProfile
from rinscal.sim.ideal_imu import ImuSynthesizer
from rinscal.sim.sensors import ThermalPlant
from rinscal.sim.trajectory import C_nb_from_euler, StepChannel, VehicleMotion

#: GNSS position noise of the tests [m] (the issue: 1-2 m white).
GNSS_SD_M = 1.5
#: The unit has been on this long when the record starts [s]: warmed up for 20 min, as the
#: paper's IMU is before its alignment in ``docs/navigation.md`` (a cold start moves its
#: accelerometer biases by 800 µg within two minutes).
WARM_S = 1200.0


def car_motion(duration_s: float, heading_deg: float) -> VehicleMotion:
    """A car at 10-18 m/s that turns three times and changes speed twice every two minutes,
    never stopping."""
    speed: list[tuple[float, float, float]] = []
    heading: list[tuple[float, float, float]] = []
    grade: list[tuple[float, float, float]] = []
    t = 5.0
    while t + 120.0 <= duration_s:
        speed += [(t, 10.0, 8.0), (t + 40.0, 10.0, -8.0)]  # 10 → 18 → 10 m/s
        heading += [(t + 15.0, 12.0, math.radians(90.0)), (t + 60.0, 15.0, math.radians(-120.0))]
        heading += [(t + 95.0, 10.0, math.radians(45.0))]
        grade += [(t + 80.0, 5.0, math.radians(3.0)), (t + 100.0, 5.0, math.radians(-3.0))]
        t += 120.0

    def channel(x0: float, steps: list[tuple[float, float, float]]) -> StepChannel:
        return StepChannel(
            x0, tuple(s[0] for s in steps), tuple(s[1] for s in steps), tuple(s[2] for s in steps)
        )

    return VehicleMotion(
        lat_deg=32.06,
        lon_deg=118.78,
        alt_m=10.0,
        speed=channel(10.0, speed),
        heading=channel(math.radians(heading_deg), heading),
        grade=channel(0.0, grade),
        duration_s=duration_s,
        stationary_until=0.0,
    )


@dataclass(frozen=True)
class Drive:
    """Raw increments, truth at 1 Hz and the noisy track of one simulated drive."""

    dt: float
    dtheta: np.ndarray  # (n, 3) [rad]
    dv: np.ndarray  # (n, 3) [m/s]
    t: np.ndarray  # (m,) [s] truth and track times (whole seconds)
    lat: np.ndarray  # (m,) true [rad]
    lon: np.ndarray
    alt: np.ndarray  # (m,) [m]
    v_n: np.ndarray  # (m, 3) true ENU velocity [m/s]
    C_nr: np.ndarray  # (m, 3, 3) true attitude of the IMU frame r
    track: GnssTrack  # noisy positions, σ = GNSS_SD_M
    noisy: np.ndarray  # (m, 3) the track's lat, lon, alt [rad, rad, m]


def paper_noise(imu: ImuConfig) -> ImuNoise:
    """The filter's noise from the plant's data sheet (white noise), priors covering the
    turn-on offsets and thermal bias of a warm unit (0.05 °/h, 1000 µg: the ``paper``
    accelerometers sit 700-900 µg off at 20 °C) and bias random walks of 0.003 °/h/√h
    and 30 µg/√h, above the data sheet's and above the warm unit's thermal drift (its
    biases move by 0.002 °/h and 20 µg between 20 and 60 min after power-on)."""
    wd = imu.noise.white_density_si()
    rw = imu.noise.bias_rw_si()
    return ImuNoise(
        gyro_noise_density=float(wd[0]),
        accel_noise_density=float(wd[3]),
        gyro_bias_sd=math.radians(0.05) / 3600.0,
        accel_bias_sd=1000e-6 * 9.80665,
        gyro_bias_rw=max(float(rw[0]), math.radians(0.003) / 3600.0 / 60.0),
        accel_bias_rw=max(float(rw[3]), 30e-6 * 9.80665 / 60.0),
    )


def simulate_drive(
    duration_s: float,
    seed: int,
    heading_deg: float = 73.0,
    rate_hz: float = 50.0,
    thermal: bool = True,
    noise: bool = True,
    turn_on: bool = True,
    powered_s: float = WARM_S,
    schedule: RotationSchedule | None = None,
) -> Drive:
    """The ``paper`` IMU on :func:`car_motion` for ``duration_s``, and its GNSS track
    (``thermal``, ``noise``, ``turn_on``: which of the plant's errors to include; the
    track is noisy whatever they are). The unit was switched on ``powered_s`` before the
    record starts (0: a cold start as the drive begins). ``schedule``: the turntable turning
    the IMU about the body's z axis (default none: strapped down)."""
    imu = load_imu("paper")
    route = car_motion(duration_s, heading_deg)
    plant = ThermalPlant(
        imu,
        ChamberProfile.constant(20.0),
        powered_s + duration_s,
        rate_hz,
        seed=seed,
        thermal=thermal,
        noise=noise,
        turn_on=turn_on,
        schedule=schedule,
    )
    syn = ImuSynthesizer(route, schedule or RotationSchedule.none(), rate_hz)
    dt = 1.0 / rate_hz
    per_s = round(rate_hz)
    dth, dvs, t, lat, lon, alt, vel, eul = [], [], [], [], [], [], [], []
    for ch in syn.chunks(duration_s, 300.0):
        e = plant(powered_s + ch.t - 0.5 * dt, ch.dtheta / dt, ch.dv / dt)
        dth.append(ch.dtheta + e[:, :3] * dt)
        dvs.append(ch.dv + e[:, 3:] * dt)
        sel = (ch.k0 + np.arange(1, ch.n + 1)) % per_s == 0
        t.append(ch.t[sel])
        lat.append(ch.lat[sel])
        lon.append(ch.lon[sel])
        alt.append(ch.alt[sel])
        vel.append(ch.v_n[sel])
        eul.append(C_nb_from_euler(ch.euler[sel]) @ C_br(ch.encoder[sel]))
    tt = np.round(np.concatenate(t), 9)
    la, lo, al = np.concatenate(lat), np.concatenate(lon), np.concatenate(alt)
    rng = np.random.default_rng(seed + 1000)
    noise_enu = rng.normal(0.0, GNSS_SD_M, (tt.size, 3))
    rn, re = earth.principal_radii(la)
    noisy = np.column_stack(
        [
            la + noise_enu[:, 1] / (rn + al),
            lo + noise_enu[:, 0] / ((re + al) * np.cos(la)),
            al + noise_enu[:, 2],
        ]
    )
    track = GnssTrack(tt, noisy[:, 0], noisy[:, 1], noisy[:, 2], GNSS_SD_M)
    return Drive(
        dt,
        np.concatenate(dth),
        np.concatenate(dvs),
        tt,
        la,
        lo,
        al,
        np.concatenate(vel),
        np.concatenate(eul),
        track,
        noisy,
    )
