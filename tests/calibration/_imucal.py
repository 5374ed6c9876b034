"""A known IMU calibration and the sensor-error model written out independently of
:mod:`rinscal.sensormodel`, for the tests of a model file that holds an IMU calibration."""

from __future__ import annotations

import math

import numpy as np

from rinscal.schema import CHANNELS
from rinscal.sensormodel import ImuCalibration

T0 = 20.0
T_RANGE = (0.0, 45.0)
#: Laws in temperature, constant first, about T0 [the parameter's table unit per °C^k].
LAWS: dict[str, tuple[float, ...]] = {
    "gyro_sf_x": (150.0, 0.8),
    "gyro_sf_y": (-80.0, -0.5, 0.01),
    "gyro_sf_z": (40.0, 0.3),
    "gyro_sf_asym_x": (5.0,),
    "gyro_sf_asym_z": (-3.0, 0.05),
    "gyro_sf_quad_y": (1.5,),
    "gyro_sf_quad_z": (2.0, -0.02),
    "gyro_mis_xy": (20.0, 0.1),
    "gyro_mis_xz": (-5.0, 0.05),
    "gyro_mis_yx": (-15.0,),
    "gyro_mis_yz": (12.0, -0.08),
    "gyro_mis_zx": (8.0,),
    "gyro_mis_zy": (-9.0, 0.02),
    "accel_sf_x": (300.0, 2.0),
    "accel_sf_y": (-200.0, -1.0),
    "accel_sf_z": (100.0, 1.0, 0.02),
    "accel_sf_quad_x": (20.0,),
    "accel_sf_quad_y": (-10.0, 0.2),
    "accel_sf_quad_z": (-15.0, 0.3),
    "accel_mis_xy": (30.0, -0.2),
    "accel_mis_xz": (-12.0,),
    "accel_mis_yx": (7.0, 0.1),
    "accel_mis_yz": (25.0,),
    "accel_mis_zx": (-18.0, 0.15),
    "accel_mis_zy": (4.0,),
}

# the units, written out here rather than taken from rinscal
_PPM = 1e-6
_ARCSEC = math.pi / 180.0 / 3600.0
_PPM_PER_DPS = 1e-6 / (math.pi / 180.0)  # ppm per deg/s -> 1/(rad/s)
_G = 9.80665
_UG_PER_G2 = 1e-6 * _G / _G**2  # µg/g² -> 1/(m/s²)
DEG_PER_H = math.pi / 180.0 / 3600.0  # rad/s of one deg/h
UG = 1e-6 * _G  # m/s² of one µg
PHYSICAL = np.array([DEG_PER_H] * 3 + [UG] * 3)


def calibration() -> ImuCalibration:
    """The known calibration (no biases: the thermal model holds the bias)."""
    return ImuCalibration(t0_c=T0, t_range_c=T_RANGE, t_coefs=dict(LAWS), source="test truth")


def _law(name: str, temp: np.ndarray) -> np.ndarray:
    d = np.clip(temp, *T_RANGE) - T0
    return sum(c * d**k for k, c in enumerate(LAWS.get(name, ())))


def forward(s: np.ndarray, temp: np.ndarray) -> np.ndarray:
    """Output [SI] of the six channels for the true input ``s`` (n, 6) [rad/s, m/s²] at the
    channel temperatures ``temp`` (n, 6) [°C]: ``u = (I + M) s``, ``y = (1 + k) u + a |u| +
    q u²``, every term evaluated here from :data:`LAWS`."""
    out = np.empty_like(s)
    axes = "xyz"
    for base, sensor in ((0, "gyro"), (3, "accel")):
        quad_unit = _PPM_PER_DPS if sensor == "gyro" else _UG_PER_G2
        for j, a in enumerate(axes):
            tj = temp[:, base + j]
            u = s[:, base + j].copy()
            for k, b in enumerate(axes):
                if k != j:
                    u += _law(f"{sensor}_mis_{a}{b}", tj) * _ARCSEC * s[:, base + k]
            sf = _law(f"{sensor}_sf_{a}", tj) * _PPM
            asym = _law(f"{sensor}_sf_asym_{a}", tj) * _PPM
            quad = _law(f"{sensor}_sf_quad_{a}", tj) * quad_unit
            out[:, base + j] = (1 + sf) * u + asym * np.abs(u) + quad * u * u
    return out


def pulse_meta(rate_hz: float) -> dict:
    """Metadata of a log in pulses (counts per sample) with nominal weights of 1″ and
    1e-4 m/s per pulse."""
    k = {c: (_ARCSEC if c.startswith("gyro") else 1e-4) * rate_hz for c in CHANNELS}
    return {"units": {c: "pulse" for c in CHANNELS}, "unit_to_si": k}
