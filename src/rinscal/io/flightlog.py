"""Read PX4 ULog (``.ulg``) and ArduPilot DataFlash (``.bin``) logs as calibration logs.

A flight controller's warm-up log becomes a canonical log (:mod:`rinscal.schema`), one run
per IMU instance read:

``time_s``
    the sample time since boot [s] (PX4 ``timestamp_sample`` of ``sensor_gyro``; ArduPilot
    ``TimeUS`` of ``IMU``): the power-on the schema asks for.
``gyro_x`` .. ``accel_z``
    rad/s and m/s² as the autopilot logs them (PX4: the driver's output, in the board frame
    of the driver's rotation, before any calibration; ArduPilot: with the board rotation
    ``AHRS_ORIENTATION`` taken back out and an active ``INS_TCAL`` correction undone, i.e. in
    the frame and state ArduPilot's temperature calibration applies to).
temperatures
    PX4: ``temp_gyro_*`` from ``sensor_gyro``, ``temp_accel_*`` from ``sensor_accel``;
    ArduPilot: the one ``IMU.T`` as ``temp_in`` [°C].

Joining PX4's gyro and accelerometer (two topics, each with its own sample times): every
``sensor_gyro`` sample is a row; the accelerometer and its temperature are interpolated
linearly at the gyro's sample time (``join="interpolate"``, exact where both share the
sample time, as one chip's gyro and accelerometer do), or taken from the nearest
accelerometer sample (``join="nearest"``). Gyro rows outside the accelerometer's time span
are left out; across an accelerometer gap longer than 3 of its median intervals (nearest:
farther than 1.5) the accelerometer channels are NaN, a dropped sample (the temperature is
still interpolated: it changes slowly). Gyro samples whose time does not increase are left
out and counted in :attr:`rinscal.io.flightinfo.FlightLog.notes`.

Active thermal corrections (see :mod:`rinscal.firmware`): ArduPilot's ``IMU`` message carries
``INS_TCALn`` when it is enabled, so it is undone, with the parameters in force at each
sample (parameter changes in the log are followed). PX4 logs ``sensor_gyro``/
``sensor_accel`` before its ``TC_*`` correction, so an enabled ``TC_*`` set is reported and
recorded, and nothing is undone (undoing it would add the correction to raw data).
ArduPilot's IMUs 4 and 5 keep their parameters under ``INS4_``/``INS5_`` (see
:mod:`rinscal.firmware`). PX4 drivers before v1.11 applied the ``CAL_GYRO*``/``CAL_ACC*``
offsets and scales before publishing; non-default ones on such a version (``ver_sw_release``,
or none logged) are named in a note, and nothing is undone.

Speed: ``pyulog`` parses the ULog definitions (formats, parameters, info); the data section
is walked by a compiled scanner that copies only the wanted topics' messages, because
``pyulog``'s per-message Python loop takes about a minute for a one-hour, three-instance
1 kHz log (the figure is in ``docs/flightlogs.md``). A log the scanner cannot walk (appended
data, a corrupt message) is read by ``pyulog`` itself. DataFlash is indexed by ``pymavlink``
(``DFReader_binary``'s offsets per message type) and its ``IMU``/``PARM`` messages are
decoded as numpy records.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pandas as pd

from rinscal.errors import LogError
from rinscal.io.dataflash import _ardupilot_frame, _df_imu, _df_info, _scan_dataflash
from rinscal.io.flightinfo import FLIGHT_FORMATS, FlightLog, FlightLogInfo, FlightLogOptions
from rinscal.io.ulog import _px4_frame, _scan_ulog, _ulog_info

__all__ = [
    "iter_flight_runs",
    "read_flight_log",
    "scan_flight_log",
]


def _flight_path(path: str | os.PathLike[str]) -> tuple[Path, str]:
    p = Path(path)
    kind = FLIGHT_FORMATS.get(p.suffix.lower())
    if kind is None:
        raise LogError(f"{p}: not a flight log suffix (use {', '.join(FLIGHT_FORMATS)})")
    if not p.exists():
        raise LogError(f"{p}: no such file")
    if p.is_dir():
        raise LogError(f"{p}: is a folder, not a log file")
    return p, kind


def scan_flight_log(path: str | os.PathLike[str]) -> FlightLogInfo:
    """What a ULog or DataFlash log holds: IMU instances, device ids, parameters.

    Cheap next to :func:`read_flight_log` (the samples are not decoded, except the
    DataFlash ``IMU`` instance field).

    Raises
    ------
    LogError
        Not a ULog/DataFlash file, a damaged header, or no IMU data (naming the file).
    """
    p, kind = _flight_path(path)
    if kind == "ulog":
        info = _ulog_info(_scan_ulog(p))
    else:
        scan = _scan_dataflash(p)
        info = _df_info(scan)
    _require_imus(info)
    return info


def _require_imus(info: FlightLogInfo) -> None:
    if not info.instances:
        what = "sensor_gyro/sensor_accel topics" if info.autopilot == "px4" else "IMU messages"
        raise LogError(f"{info.path}: no IMU data: the log has no {what}")


def iter_flight_runs(
    path: str | os.PathLike[str], options: FlightLogOptions | None = None
) -> tuple[FlightLogInfo, Iterator[pd.DataFrame], list[str]]:
    """A flight log's info and its runs (one frame per selected instance), made one by one.

    Memory holds one instance's samples at a time. The list of notes (truncation, samples
    left out) fills as the runs are made.

    Raises
    ------
    LogError
        As :func:`read_flight_log`; the choice of instance is checked before any run is made.
    """
    options = options or FlightLogOptions()
    p, kind = _flight_path(path)
    notes: list[str] = []
    stem = options.run or p.stem
    scan: Any = None
    imu: Any = None
    if kind == "ulog":
        scan = _scan_ulog(p)
        info = _ulog_info(scan)
    else:
        scan_df = _scan_dataflash(p)
        imu = _df_imu(scan_df)
        info = _df_info(scan_df)
        del scan_df
    _require_imus(info)
    chosen = info.selected(options)
    notes.extend(info.notes)

    def runs() -> Iterator[pd.DataFrame]:
        nonlocal scan, imu
        for k, inst in enumerate(chosen):
            run = stem if len(chosen) == 1 else f"{stem}/imu{inst.index}"
            if kind == "ulog":
                frame = _px4_frame(scan, inst, options.join, run, notes)
            else:
                frame = _ardupilot_frame(info, imu, inst, run, notes)
            if k == len(chosen) - 1:  # the file's pages and records go before the last run
                scan = imu = None  # is used (the frames copy what they need)
            yield frame

    return info, runs(), notes


def read_flight_log(
    path: str | os.PathLike[str], options: FlightLogOptions | None = None
) -> FlightLog:
    """Read a ULog or DataFlash log as a canonical calibration log (see the module doc).

    Parameters
    ----------
    path : path-like
        ``.ulg`` (PX4) or ``.bin`` (ArduPilot DataFlash).
    options : FlightLogOptions, optional
        Instance, join and run name (default: the only instance).

    Returns
    -------
    FlightLog
        ``frame`` holds one run per selected instance, rows in time order (not validated:
        :func:`rinscal.io.tables.read_log_source` validates it).

    Raises
    ------
    LogError
        Naming the file and, where it applies, the instance, topic or field.
    """
    info, runs, notes = iter_flight_runs(path, options)
    frames = list(runs)
    frame = frames[0] if len(frames) == 1 else pd.concat(frames, ignore_index=True)
    return FlightLog(info, frame, tuple(notes))
