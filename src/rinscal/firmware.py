"""PX4 and ArduPilot thermal-correction parameters: names, and the correction they apply.

Used by two layers: the flight-log readers (:mod:`rinscal.io.flightlog`, which detect an
active correction and undo it where the log carries it) and the exports
(:mod:`rinscal.calibration.export`, which write these parameters). Temperatures in °C,
sensor values in SI (rad/s, m/s²).

PX4 drivers before v1.11 (``CAL_GYRO<n>_*``, ``CAL_ACC<n>_*``)
    applied the ``CAL_<GYRO|ACC><n>_<X|Y|Z>OFF`` offsets and ``..._<X|Y|Z>SCALE`` scales of
    the slot whose ``CAL_<GYRO|ACC><n>_ID`` is the sensor's ``device_id`` before publishing
    ``sensor_gyro``/``sensor_accel``; PX4's ``process_sensor_caldata.py`` asks for them to be
    reset to defaults (0 and 1) before a thermal-calibration log. From v1.11 the drivers
    publish their raw output and the calibration is applied downstream. A ULog says its
    version in the ``ver_sw_release`` info message (``0xAABBCCTT``: major, minor, patch,
    type).
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

    Parameter names (``AP_InertialSensor.cpp``, ``AP_InertialSensor_Params.cpp``): IMUs 1-3
    (instances 0-2) have ``INS_TCAL<n>_*``, ``INS_<GYR|ACC><n>_CALTEMP`` and the ids
    ``INS_GYR_ID``, ``INS_GYR2_ID``, ``INS_GYR3_ID``; IMUs 4 and 5 (instances 3, 4) keep
    theirs in the groups ``INS4_``/``INS5_``: ``INS4_TCAL_*``, ``INS4_<GYR|ACC>_CALTEMP``,
    ``INS4_GYR_ID``, ``INS4_ACC_ID``. ArduPilot has no parameters for a sixth IMU.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

__all__ = [
    "ARDUPILOT_IMUS",
    "ARDUPILOT_SCALE",
    "ARDUPILOT_TREF_C",
    "PX4_RAW_DRIVERS_FROM",
    "ardupilot_caltemp_param",
    "ardupilot_id_param",
    "ardupilot_tcal",
    "ardupilot_tcal_enabled",
    "ardupilot_tcal_params",
    "ardupilot_tcal_prefix",
    "px4_driver_calibration",
    "px4_tc_slot",
]

#: ArduPilot's fixed reference temperature [°C].
ARDUPILOT_TREF_C = 35.0
#: ArduPilot stores coefficients multiplied by this.
ARDUPILOT_SCALE = 1.0e6
#: ArduPilot's default ``INS_<GYR|ACC><n>_CALTEMP`` [°C] ("not set").
ARDUPILOT_CALTEMP_DEFAULT_C = -300.0
_PX4_TAG = {"gyro": "G", "accel": "A"}
_PX4_CAL = {"gyro": "GYRO", "accel": "ACC"}
#: First PX4 release (major, minor) whose drivers publish output without ``CAL_*`` applied.
PX4_RAW_DRIVERS_FROM = (1, 11)
_AP_TAG = {"gyro": "GYR", "accel": "ACC"}
_AXES = ("X", "Y", "Z")
#: IMUs ArduPilot has parameters for (``INS_MAX_INSTANCES`` is at most 5).
ARDUPILOT_IMUS = 5


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


def px4_driver_calibration(
    params: Mapping[str, float], sensor: str, device_id: int | None
) -> list[str]:
    """``CAL_*`` offsets and scales not at their defaults for a sensor, by name.

    Parameters
    ----------
    params : mapping
        The log's parameters.
    sensor : {"gyro", "accel"}
    device_id : int or None
        The sensor's ``device_id``; the slot ``n`` whose ``CAL_<GYRO|ACC><n>_ID`` equals it
        is the one a driver before v1.11 applied (None: no slot).

    Returns
    -------
    list of str
        E.g. ``["CAL_GYRO0_XOFF", "CAL_GYRO0_ZSCALE"]`` (offset ≠ 0, scale ≠ 1); empty when
        they are at their defaults or no slot matches.
    """
    if device_id is None:
        return []
    tag = _PX4_CAL[sensor]
    for n in range(4):
        pid = params.get(f"CAL_{tag}{n}_ID")
        if pid is None or int(pid) & 0xFFFFFFFF != int(device_id) & 0xFFFFFFFF:
            continue
        names = []
        for axis in _AXES:
            for kind, default in (("OFF", 0.0), ("SCALE", 1.0)):
                name = f"CAL_{tag}{n}_{axis}{kind}"
                if float(params.get(name, default)) != default:
                    names.append(name)
        return names
    return []


def ardupilot_tcal_enabled(params: Mapping[str, float], instance: int) -> bool:
    """Whether ArduPilot applies ``INS_TCAL<instance+1>`` (``ENABLE`` = 1; 2 is learning)."""
    return int(params.get(f"{ardupilot_tcal_prefix(instance)}ENABLE", 0)) == 1


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
    pre = ardupilot_tcal_prefix(instance)
    temp_c = np.asarray(temp_c, dtype=np.float64)
    out = np.zeros((temp_c.size, 3))
    cal = float(params.get(ardupilot_caltemp_param(sensor, instance), ARDUPILOT_CALTEMP_DEFAULT_C))
    if not ardupilot_tcal_enabled(params, instance):
        return out
    lo = float(params.get(f"{pre}TMIN", 0.0))  # ArduPilot's defaults
    hi = float(params.get(f"{pre}TMAX", 0.0))
    d = np.clip(temp_c, lo, hi) - ARDUPILOT_TREF_C
    d_cal = min(max(cal, lo), hi) - ARDUPILOT_TREF_C
    for j, axis in enumerate(_AXES):
        c1, c2, c3 = (
            float(params.get(f"{pre}{_AP_TAG[sensor]}{k}_{axis}", 0.0)) / ARDUPILOT_SCALE
            for k in (1, 2, 3)
        )
        out[:, j] = ((c1 + (c2 + c3 * d) * d) * d) - ((c1 + (c2 + c3 * d_cal) * d_cal) * d_cal)
    return out


def ardupilot_tcal_params(name: str, instance: int) -> bool:
    """Whether parameter ``name`` changes the correction of IMU ``instance`` (0-based)."""
    return name.startswith(ardupilot_tcal_prefix(instance)) or name in (
        ardupilot_caltemp_param("gyro", instance),
        ardupilot_caltemp_param("accel", instance),
    )


def _ardupilot_group(instance: int) -> str:
    """``"INS4_"``/``"INS5_"``: the parameter group of IMUs 4 and 5 ("" for IMUs 1-3)."""
    if isinstance(instance, bool) or not 0 <= instance < ARDUPILOT_IMUS:
        raise ValueError(
            f"ArduPilot has parameters for IMU instances 0 to {ARDUPILOT_IMUS - 1}, "
            f"not {instance!r}"
        )
    return f"INS{instance + 1}_" if instance >= 3 else ""


def ardupilot_tcal_prefix(instance: int) -> str:
    """Prefix of an IMU's temperature-calibration parameters: ``INS_TCAL1_`` .. ``INS_TCAL3_``
    for instances 0-2, ``INS4_TCAL_``, ``INS5_TCAL_`` for 3 and 4.

    Raises
    ------
    ValueError
        For an instance ArduPilot has no parameters for.
    """
    group = _ardupilot_group(instance)
    return f"{group}TCAL_" if group else f"INS_TCAL{instance + 1}_"


def ardupilot_caltemp_param(sensor: str, instance: int) -> str:
    """An IMU's calibration-temperature parameter (``INS_GYR1_CALTEMP``, ``INS4_ACC_CALTEMP``)."""
    group = _ardupilot_group(instance)
    tag = _AP_TAG[sensor]
    return f"{group}{tag}_CALTEMP" if group else f"INS_{tag}{instance + 1}_CALTEMP"


def ardupilot_id_param(sensor: str, instance: int) -> str:
    """An IMU's device-id parameter (``INS_GYR_ID``, ``INS_ACC2_ID``, ``INS4_GYR_ID``)."""
    group = _ardupilot_group(instance)
    tag = _AP_TAG[sensor]
    return f"{group}{tag}_ID" if group else f"INS_{tag}{'' if instance == 0 else instance + 1}_ID"
