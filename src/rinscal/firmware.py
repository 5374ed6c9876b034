"""PX4 and ArduPilot thermal-correction parameters: names, and the correction they apply.

Used by two layers: the flight-log readers (:mod:`rinscal.flightlog`, which detect an active
correction and undo it where the log carries it) and the exports
(:mod:`rinscal.calibration.export`, which write these parameters). Temperatures in °C,
sensor values in SI (rad/s, m/s²).

PX4 (``src/modules/temperature_compensation``; ``TC_<G|A><slot>_*``)
    ``offset = X0 + X1·d + X2·d² + X3·d³``, ``d = clamp(T, TMIN, TMAX) − TREF``, subtracted
    from the sensor whose ``device_id`` equals ``TC_<G|A><slot>_ID`` when
    ``TC_<G|A>_ENABLE`` = 1. PX4 subtracts it downstream of the driver
    (``calibration::Gyroscope::Correct``: ``R · (data − thermal_offset − offset)``, in
    ``VehicleIMU``/``VehicleAngularVelocity``); the logged ``sensor_gyro``/``sensor_accel``
    are the driver's output *before* it, so a ULog's sensor topics carry no thermal
    correction to undo.
ArduPilot (``AP_InertialSensor_tempcal.cpp``; ``INS_TCAL<n>_*``, n = instance + 1)
    when ``INS_TCAL<n>_ENABLE`` = 1: ``v −= P(clamp(T) − 35) − P(clamp(CALTEMP) − 35)`` with
    ``P(d) = (c1 + (c2 + c3·d)·d)·d·1e−6``; both ``T`` and ``CALTEMP`` =
    ``INS_<GYR|ACC><n>_CALTEMP`` are clamped to ``[TMIN, TMAX]`` (the firmware's
    ``TCal::correct_sensor``; an unset CALTEMP, −300 °C by default, becomes TMIN there).
    ArduPilot's ``tempcal_IMU.py`` instead skips the correction for a CALTEMP below −80 °C;
    we follow the firmware, which made the log. The correction is applied in the sensor
    frame, before the board rotation ``AHRS_ORIENTATION``; the ``IMU`` log message carries it
    (and the rotation).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

__all__ = [
    "ARDUPILOT_SCALE",
    "ARDUPILOT_TREF_C",
    "ardupilot_id_param",
    "ardupilot_tcal",
    "ardupilot_tcal_enabled",
    "ardupilot_tcal_params",
    "px4_tc_slot",
]

#: ArduPilot's fixed reference temperature [°C].
ARDUPILOT_TREF_C = 35.0
#: ArduPilot stores coefficients multiplied by this.
ARDUPILOT_SCALE = 1.0e6
#: ArduPilot's default ``INS_<GYR|ACC><n>_CALTEMP`` [°C] ("not set").
ARDUPILOT_CALTEMP_DEFAULT_C = -300.0
_PX4_TAG = {"gyro": "G", "accel": "A"}
_AP_TAG = {"gyro": "GYR", "accel": "ACC"}
_AXES = ("X", "Y", "Z")


def px4_tc_slot(params: Mapping[str, float], sensor: str, device_id: int) -> int | None:
    """The ``TC_<G|A><slot>`` set PX4 applies to a sensor, or None (disabled or no match).

    Parameters
    ----------
    params : mapping
        The log's parameters.
    sensor : {"gyro", "accel"}
    device_id : int
        The sensor's ``device_id`` (uint32; PX4 stores the ``ID`` parameter as int32).
    """
    tag = _PX4_TAG[sensor]
    if int(params.get(f"TC_{tag}_ENABLE", 0)) != 1:
        return None
    for slot in range(4):
        pid = params.get(f"TC_{tag}{slot}_ID")
        if pid is not None and int(pid) & 0xFFFFFFFF == int(device_id) & 0xFFFFFFFF:
            return slot
    return None


def ardupilot_tcal_enabled(params: Mapping[str, float], instance: int) -> bool:
    """Whether ArduPilot applies ``INS_TCAL<instance+1>`` (``ENABLE`` = 1; 2 is learning)."""
    return int(params.get(f"INS_TCAL{instance + 1}_ENABLE", 0)) == 1


def ardupilot_tcal(
    params: Mapping[str, float], instance: int, sensor: str, temp_c: np.ndarray
) -> np.ndarray:
    """The correction ArduPilot subtracts from a sensor at temperatures ``temp_c``.

    Parameters
    ----------
    params : mapping
        Parameters in force (``INS_TCAL<n>_*``, ``INS_<GYR|ACC><n>_CALTEMP``).
    instance : int
        IMU instance, 0-based (the ``I`` field of the ``IMU`` message).
    sensor : {"gyro", "accel"}
    temp_c : ndarray, shape (n,)
        Sensor temperature [°C].

    Returns
    -------
    ndarray, shape (n, 3)
        ``P(clamp(T) − 35) − P(clamp(CALTEMP) − 35)`` per axis [rad/s or m/s²]; zeros when
        the set is not enabled.
    """
    n = instance + 1
    temp_c = np.asarray(temp_c, dtype=np.float64)
    out = np.zeros((temp_c.size, 3))
    cal = float(params.get(f"INS_{_AP_TAG[sensor]}{n}_CALTEMP", ARDUPILOT_CALTEMP_DEFAULT_C))
    if not ardupilot_tcal_enabled(params, instance):
        return out
    lo = float(params.get(f"INS_TCAL{n}_TMIN", 0.0))  # ArduPilot's defaults
    hi = float(params.get(f"INS_TCAL{n}_TMAX", 0.0))
    d = np.clip(temp_c, lo, hi) - ARDUPILOT_TREF_C
    d_cal = min(max(cal, lo), hi) - ARDUPILOT_TREF_C
    for j, axis in enumerate(_AXES):
        c1, c2, c3 = (
            float(params.get(f"INS_TCAL{n}_{_AP_TAG[sensor]}{k}_{axis}", 0.0)) / ARDUPILOT_SCALE
            for k in (1, 2, 3)
        )
        out[:, j] = ((c1 + (c2 + c3 * d) * d) * d) - ((c1 + (c2 + c3 * d_cal) * d_cal) * d_cal)
    return out


def ardupilot_tcal_params(name: str, instance: int) -> bool:
    """Whether parameter ``name`` changes the correction of IMU ``instance`` (0-based)."""
    n = instance + 1
    return name.startswith(f"INS_TCAL{n}_") or name in (
        f"INS_GYR{n}_CALTEMP",
        f"INS_ACC{n}_CALTEMP",
    )


def ardupilot_id_param(sensor: str, instance: int) -> str:
    """ArduPilot's device-id parameter of an IMU instance (``INS_GYR_ID``, ``INS_ACC2_ID``)."""
    return f"INS_{_AP_TAG[sensor]}{'' if instance == 0 else instance + 1}_ID"
