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
out and counted in :attr:`FlightLog.notes`.

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

import contextlib
import errno
import io as _io
import itertools
import os
import struct
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numba
import numpy as np
import pandas as pd

from rinscal.errors import LogError, describe_os_error
from rinscal.firmware import (
    ARDUPILOT_IMUS,
    PX4_RAW_DRIVERS_FROM,
    ardupilot_id_param,
    ardupilot_tcal,
    ardupilot_tcal_enabled,
    ardupilot_tcal_params,
    ardupilot_tcal_prefix,
    px4_driver_calibration,
    px4_tc_slot,
)
from rinscal.schema import ACCEL_CHANNELS, GYRO_CHANNELS, RUN, TEMP_IN, TIME
from rinscal.units import US_TO_S

__all__ = [
    "FLIGHT_FORMATS",
    "FlightLog",
    "FlightLogInfo",
    "FlightLogOptions",
    "ImuInstance",
    "iter_flight_runs",
    "read_flight_log",
    "scan_flight_log",
]

#: Flight-log formats by suffix.
FLIGHT_FORMATS: dict[str, str] = {".ulg": "ulog", ".bin": "dataflash"}
#: Units of the channels of a flight log.
FLIGHT_UNITS: dict[str, str] = {"gyro": "rad/s", "accel": "m/s^2"}
_ULOG_MAGIC = b"ULog\x01\x12\x35"
_DF_MAGIC = b"\xa3\x95\x80"
#: ULog message types (A B C F I L M O P Q R S; D is handled apart).
_KNOWN = np.zeros(256, dtype=np.bool_)
_KNOWN[np.frombuffer(b"ABCFILMOPQRS", dtype=np.uint8)] = True
_GAP_INTERPOLATE = 3.0  # accel gap (in median intervals) across which no value is made up
_GAP_NEAREST = 1.5


@dataclass(frozen=True)
class FlightLogOptions:
    """How to read a flight log.

    Attributes
    ----------
    instance : int, "all" or None
        The IMU instance (0-based, PX4 ``multi_id``, ArduPilot ``IMU.I``); ``"all"``: every
        instance, one run each; None: the only one (an error naming them when there are
        several).
    join : {"interpolate", "nearest"}
        How PX4's accelerometer is put on the gyro's sample times.
    run : str, optional
        Run name of a single instance (default: the file's stem); with several instances
        each run is ``<name>/imu<N>``.
    """

    instance: int | Literal["all"] | None = None
    join: Literal["interpolate", "nearest"] = "interpolate"
    run: str | None = None

    def __post_init__(self) -> None:
        if self.join not in ("interpolate", "nearest"):
            raise LogError(f"join must be 'interpolate' or 'nearest', got {self.join!r}")
        if self.instance is not None and self.instance != "all":
            if isinstance(self.instance, bool) or not isinstance(self.instance, int):
                raise LogError(f"instance must be an integer >= 0 or 'all', got {self.instance!r}")
            if self.instance < 0:
                raise LogError(f"instance must be >= 0, got {self.instance}")


@dataclass(frozen=True)
class ImuInstance:
    """One IMU of a flight log: its instance, device ids and active thermal correction."""

    index: int
    gyro_id: int | None
    accel_id: int | None
    samples: int
    #: What the autopilot's own thermal correction does on this instance (text), or None.
    correction: str | None = None

    def label(self) -> str:
        """``"0 (gyro 2424842, accel 2424842, 7,200 samples)"``."""
        return (
            f"{self.index} (gyro {self.gyro_id}, accel {self.accel_id}, {self.samples:,} samples)"
        )


@dataclass(frozen=True)
class FlightLogInfo:
    """What a flight log holds, without its samples (see :func:`scan_flight_log`)."""

    path: Path
    autopilot: Literal["px4", "ardupilot"]
    instances: tuple[ImuInstance, ...]
    params: dict[str, float]
    #: Parameters changed while logging: (time since boot [s], name, value).
    changed: tuple[tuple[float, str, float], ...] = ()
    notes: tuple[str, ...] = ()

    def instance(self, index: int) -> ImuInstance:
        """The instance ``index``, or a LogError listing the instances there are."""
        for inst in self.instances:
            if inst.index == index:
                return inst
        raise LogError(
            f"{self.path}: no IMU instance {index}; the log has "
            + ("; ".join(i.label() for i in self.instances) or "none")
        )

    def selected(self, options: FlightLogOptions) -> tuple[ImuInstance, ...]:
        """The instances ``options`` selects (a LogError when the choice is ambiguous)."""
        if options.instance == "all":
            return self.instances
        if options.instance is None:
            if len(self.instances) == 1:
                return self.instances
            raise LogError(
                f"{self.path}: {len(self.instances)} IMU instances: "
                + "; ".join(i.label() for i in self.instances)
                + "; choose one with --instance N (or --instance all: one run per instance)"
            )
        return (self.instance(int(options.instance)),)

    def meta(self, options: FlightLogOptions) -> dict[str, Any]:
        """Log metadata for the model file: units, autopilot, instance, device ids."""
        meta: dict[str, Any] = {
            "units": dict(FLIGHT_UNITS),
            "autopilot": self.autopilot,
            "log": self.path.name,
        }
        chosen = self.selected(options)
        if len(chosen) == 1:
            inst = chosen[0]
            meta["instance"] = inst.index
            ids = {k: v for k, v in (("gyro", inst.gyro_id), ("accel", inst.accel_id)) if v}
            if ids:
                meta["device_ids"] = ids
            if inst.correction:
                meta["autopilot_correction"] = inst.correction
        return meta


@dataclass(frozen=True)
class FlightLog:
    """A flight log read: its info and the canonical log of the selected instances."""

    info: FlightLogInfo
    frame: pd.DataFrame
    notes: tuple[str, ...] = field(default=())


# --------------------------------------------------------------------------- scanners


@numba.njit(cache=True)
def _ulog_walk(buf: np.ndarray, start: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int]:
    """Walk a ULog from ``start``: data messages per msg_id, offsets of the others.

    Returns (counts per msg_id, offsets of non-data messages, the latest data timestamp
    [µs] before each of them, end offset, status): status 0
    reached the end, 1 the last message is cut (truncated file), 2 a corrupt header at the
    end offset.
    """
    counts = np.zeros(65536, dtype=np.int64)
    others = np.empty(1024, dtype=np.int64)
    stamps = np.empty(1024, dtype=np.uint64)
    last = np.uint64(0)
    n_other = 0
    pos = start
    n = buf.size
    status = 0
    while pos + 3 <= n:
        size = np.int64(buf[pos]) | (np.int64(buf[pos + 1]) << 8)
        kind = buf[pos + 2]
        if kind == 0 or size == 0:
            status = 2
            break
        if pos + 3 + size > n:
            status = 1
            break
        if kind == 68:  # 'D'
            if size < 2:
                status = 2
                break
            counts[np.int64(buf[pos + 3]) | (np.int64(buf[pos + 4]) << 8)] += 1
            if size >= 10:  # PX4 topics start with their uint64 timestamp [µs]
                ts = np.uint64(0)
                for b in range(8):
                    ts |= np.uint64(buf[pos + 5 + b]) << np.uint64(8 * b)
                if ts > last:
                    last = ts
        else:
            if not _KNOWN[kind]:
                status = 2
                break
            if n_other == others.size:
                grown = np.empty(others.size * 2, dtype=np.int64)
                grown[:n_other] = others[:n_other]
                others = grown
                grown_ts = np.empty(stamps.size * 2, dtype=np.uint64)
                grown_ts[:n_other] = stamps[:n_other]
                stamps = grown_ts
            others[n_other] = pos
            stamps[n_other] = last
            n_other += 1
        pos += 3 + size
    if status == 0 and pos != n:
        status = 1
    return counts, others[:n_other].copy(), stamps[:n_other].copy(), pos, status


@numba.njit(cache=True)
def _ulog_offsets(
    buf: np.ndarray, start: int, end: int, slot_of: np.ndarray, starts: np.ndarray
) -> np.ndarray:
    """Offsets of the data messages of the wanted msg_ids (``slot_of[id] >= 0``), by slot."""
    out = np.empty(starts[-1], dtype=np.int64)
    fill = starts[:-1].copy()
    pos = start
    while pos < end:
        size = np.int64(buf[pos]) | (np.int64(buf[pos + 1]) << 8)
        if buf[pos + 2] == 68:
            s = slot_of[np.int64(buf[pos + 3]) | (np.int64(buf[pos + 4]) << 8)]
            if s >= 0:
                out[fill[s]] = pos
                fill[s] += 1
        pos += 3 + size
    return out


@numba.njit(cache=True)
def _ulog_first(buf: np.ndarray, start: int, end: int, msg_id: int) -> int:
    """Offset of the first data message of ``msg_id`` (-1 if there is none)."""
    pos = start
    while pos < end:
        size = np.int64(buf[pos]) | (np.int64(buf[pos + 1]) << 8)
        if (
            buf[pos + 2] == 68
            and (np.int64(buf[pos + 3]) | (np.int64(buf[pos + 4]) << 8)) == msg_id
        ):
            return pos
        pos += 3 + size
    return -1


@numba.njit(cache=True)
def _gather(
    buf: np.ndarray, offsets: np.ndarray, skip: int, width: int, out: np.ndarray, sized: bool
) -> int:
    """Copy ``width`` bytes from ``offset + skip`` of each message into rows of ``out``.

    With ``sized`` (ULog), a message whose size field (uint16 at ``offset``) says it is
    shorter than ``skip - 3 + width`` is not copied; a message cut by the end of the file
    never is. The rows copied are packed at the front; returns their number.
    """
    k = 0
    for i in range(offsets.size):
        o = offsets[i]
        a = o + skip
        if a + width > buf.size:
            continue
        if sized and (np.int64(buf[o]) | (np.int64(buf[o + 1]) << 8)) + 3 < skip + width:
            continue
        out[k, :] = buf[a : a + width]
        k += 1
    return k


# --------------------------------------------------------------------------- ULog

_ULOG_TYPES = {
    "int8_t": "i1", "uint8_t": "u1", "int16_t": "<i2", "uint16_t": "<u2", "int32_t": "<i4",
    "uint32_t": "<u4", "int64_t": "<i8", "uint64_t": "<u8", "float": "<f4", "double": "<f8",
    "bool": "u1", "char": "S1",
}  # fmt: skip
_TOPICS = ("sensor_gyro", "sensor_accel")


def _ulog_dtype(formats: Mapping[str, Any], name: str) -> np.dtype:
    """Packed record type of a topic, nested types flattened as pyulog names them."""
    names: list[str] = []
    codes: list[str] = []
    offsets: list[int] = []
    pos = 0

    def walk(prefix: str, type_name: str) -> None:
        nonlocal pos
        for ftype, count, fname in formats[type_name].fields:
            if ftype in _ULOG_TYPES:
                code = np.dtype(_ULOG_TYPES[ftype])
                for k in range(max(count, 1)):
                    label = f"{prefix}{fname}[{k}]" if count > 0 else prefix + fname
                    names.append(label)
                    codes.append(code.str)
                    offsets.append(pos)
                    pos += code.itemsize
            else:
                for k in range(max(count, 1)):
                    walk(f"{prefix}{fname}[{k}]." if count > 0 else f"{prefix}{fname}.", ftype)

    walk("", name)
    while names and names[-1].split("[")[0].startswith("_padding"):  # PX4 does not log it
        pos = offsets[-1]
        names.pop(), codes.pop(), offsets.pop()
    keep = [k for k, n in enumerate(names) if not n.split("[")[0].startswith("_padding")]
    return np.dtype(
        {
            "names": [names[k] for k in keep],
            "formats": [codes[k] for k in keep],
            "offsets": [offsets[k] for k in keep],
            "itemsize": pos,
        }
    )


def _ulog_string(raw: bytes) -> str:
    return raw.decode("utf-8", errors="replace")


def _ulog_param(body: bytes) -> tuple[str, float] | None:
    """Name and value of a ULog ``P`` message payload (None if it is not a number)."""
    klen = body[0]
    ftype, _, name = _ulog_string(body[1 : 1 + klen]).partition(" ")
    value = body[1 + klen :]
    code = _ULOG_TYPES.get(ftype)
    if code is None or code == "S1" or len(value) < np.dtype(code).itemsize:
        return None
    return name, float(np.frombuffer(value, dtype=code, count=1)[0])


@dataclass
class _ULogScan:
    """A ULog walked: header (pyulog), subscriptions, data-message offsets per topic."""

    path: Path
    buf: np.ndarray
    params: dict[str, float]
    formats: Mapping[str, Any]
    subs: dict[int, tuple[str, int]]  # msg_id -> (topic, multi_id)
    counts: np.ndarray
    changed_at: list[tuple[int, str, float]]  # (time since boot [µs], name, value)
    end: int
    notes: list[str]
    fallback: Any = None  # a pyulog.ULog when the scanner could not walk the file
    #: PX4's (major, minor, patch, type) from ``ver_sw_release``; None when not logged.
    version: tuple[int, int, int, int] | None = None


def _open_buffer(p: Path) -> np.ndarray:
    size = p.stat().st_size
    if size == 0:
        return np.zeros(0, dtype=np.uint8)
    return np.memmap(p, dtype=np.uint8, mode="r")


def _check_magic(p: Path, magic: bytes, what: str, hint: str) -> None:
    with p.open("rb") as fh:
        head = fh.read(len(magic))
    if head != magic:
        found = "an empty file" if not head else f"starts with {head[:8]!r}"
        raise LogError(f"{p}: not a {what} ({found}; a {what} starts with {magic!r}){hint}")


def _pyulog(p: Path, damage: str | None = None, **kw: Any) -> Any:
    """pyulog's ULog of ``p`` (what it prints about a damaged file is kept off the terminal:
    the reader's notes say what was done). ``damage``: what the scanner found wrong, named
    when pyulog cannot read past it either."""
    from pyulog import ULog
    from pyulog.core import ULogException

    why = f"{damage}, which pyulog's parser cannot read past" if damage else None
    try:
        with contextlib.redirect_stdout(_io.StringIO()):
            return ULog(str(p), **kw)
    except ULogException as exc:
        raise LogError(f"{p}: unreadable ULog: {why or exc}") from None
    except (struct.error, IndexError, KeyError, ValueError, OverflowError) as exc:
        raise LogError(
            f"{p}: unreadable ULog: {why or f'truncated or corrupt ({exc!r})'}"
        ) from None
    except OSError as exc:
        if exc.errno not in (None, errno.EINVAL):  # the file itself (permission, I/O error)
            raise LogError(describe_os_error(exc, p)) from None
        # pyulog seeks back before the file's start while hunting for a message in garbage
        raise LogError(f"{p}: unreadable ULog: {why or 'corrupt data'} ({exc})") from None


def _scan_ulog(p: Path) -> _ULogScan:
    _check_magic(p, _ULOG_MAGIC, "ULog", "")
    head = _pyulog(
        p, "corrupt bytes in its definitions or where its data begin", parse_header_only=True
    )
    buf = _open_buffer(p)
    counts, others, stamps, end, status = _ulog_walk(buf, 16)
    notes: list[str] = []
    subs: dict[int, tuple[str, int]] = {}
    changed: list[tuple[int, str, float]] = []
    in_data = False
    for off, stamp in zip(others.tolist(), stamps.tolist(), strict=True):
        size = int(buf[off]) | (int(buf[off + 1]) << 8)
        kind = chr(buf[off + 2])
        body = bytes(buf[off + 3 : off + 3 + size])
        if kind in "ALC":
            in_data = True
        if kind == "A":
            subs[int.from_bytes(body[1:3], "little")] = (_ulog_string(body[3:]), body[0])
        elif kind == "P" and in_data:
            named = _ulog_param(body)
            if named is not None:
                changed.append((int(stamp), *named))
    params = {k: float(v) for k, v in head.initial_parameters.items()}
    version = head.get_version_info()
    if status == 2 or head.has_data_appended:
        why = "appended data" if head.has_data_appended else f"a corrupt message at byte {end}"
        notes.append(f"{why}: read by pyulog's own parser (slower), which recovers what it can")
        ulog = _pyulog(p, why, message_name_filter_list=list(_TOPICS))
        return _ULogScan(p, buf, params, head.message_formats, {},
                         counts, [], end, notes, fallback=ulog, version=version)  # fmt: skip
    if status == 1:
        notes.append(
            f"truncated: the last {buf.size - end} byte(s) are a cut message and are left out"
        )
    return _ULogScan(
        p, buf, params, head.message_formats, subs, counts, changed, end, notes, version=version
    )


def _streams(
    scan: _ULogScan, wanted: Sequence[tuple[str, int]]
) -> list[dict[str, np.ndarray] | None]:
    """Every field of some topic instances, in one pass (None for a stream not logged)."""
    if scan.fallback is not None:
        found = {(d.name, d.multi_id): d.data for d in scan.fallback.data_list}
        return [found.get(w) for w in wanted]
    slot_of = np.full(65536, -1, dtype=np.int64)
    ids_of: list[list[int]] = []
    ordered: list[int] = []
    for topic, multi_id in wanted:
        ids = [i for i, tm in scan.subs.items() if tm == (topic, multi_id) and scan.counts[i]]
        ids_of.append(ids if topic in scan.formats else [])
        for i in ids_of[-1]:
            slot_of[i] = len(ordered)
            ordered.append(i)
    starts = np.concatenate([[0], np.cumsum(scan.counts[ordered])]).astype(np.int64)
    offsets = _ulog_offsets(scan.buf, 16, scan.end, slot_of, starts)
    out: list[dict[str, np.ndarray] | None] = []
    for (topic, multi_id), ids in zip(wanted, ids_of, strict=True):
        if not ids:
            out.append(None)
            continue
        k0 = ordered.index(ids[0])
        offs = offsets[starts[k0] : starts[k0 + len(ids)]]
        if len(ids) > 1:  # several subscriptions of one stream: back in file order
            offs = np.sort(offs)
        dtype = _ulog_dtype(scan.formats, topic)
        rows = np.empty((offs.size, dtype.itemsize), dtype=np.uint8)
        k = _gather(scan.buf, offs, 5, dtype.itemsize, rows, True)
        if k < offs.size:
            scan.notes.append(f"{topic} {multi_id}: {offs.size - k} short message(s) left out")
        rec = rows[:k].view(dtype).reshape(k)
        out.append({n: rec[n] for n in dtype.names})
    return out


def _ulog_info(scan: _ULogScan) -> FlightLogInfo:
    instances = []
    log_notes = list(scan.notes)
    multi = sorted(
        {m for t, m in scan.subs.values() if t == "sensor_gyro"}
        if scan.fallback is None
        else {d.multi_id for d in scan.fallback.data_list if d.name == "sensor_gyro"}
    )
    for m in multi:
        gyro = _first(scan, "sensor_gyro", m)
        accel = _first(scan, "sensor_accel", m)
        if gyro is None:
            continue
        gid = int(gyro["device_id"]) if "device_id" in gyro else None
        aid = int(accel["device_id"]) if accel is not None and "device_id" in accel else None
        notes = []
        for sensor, did in (("gyro", gid), ("accel", aid)):
            slot = None if did is None else px4_tc_slot(scan.params, sensor, did)
            if slot is not None:
                tag = "G" if sensor == "gyro" else "A"
                notes.append(
                    f"TC_{tag}{slot} enabled for this {sensor} (device {did}); PX4 logs "
                    f"sensor_{sensor} before it, so nothing is undone"
                )
        instances.append(
            ImuInstance(m, gid, aid, _count(scan, "sensor_gyro", m), "; ".join(notes) or None)
        )
        cal = px4_driver_calibration(scan.params, "gyro", gid)
        cal += px4_driver_calibration(scan.params, "accel", aid)
        if cal and (scan.version is None or scan.version[:2] < PX4_RAW_DRIVERS_FROM):
            log_notes.append(_old_px4_note(m, cal, scan.version))
    changed = tuple((t * US_TO_S, n, v) for t, n, v in scan.changed_at)
    if scan.fallback is not None:
        changed = tuple((t * US_TO_S, n, float(v)) for t, n, v in scan.fallback.changed_parameters)
    return FlightLogInfo(scan.path, "px4", tuple(instances), scan.params, changed, tuple(log_notes))


def _old_px4_note(instance: int, names: Sequence[str], version: Sequence[int] | None) -> str:
    """What a driver before PX4 v1.11 did to the logged output, naming the parameters."""
    first = ".".join(map(str, PX4_RAW_DRIVERS_FROM))
    which = (
        f"PX4 v{version[0]}.{version[1]}.{version[2]} applied"
        if version is not None
        else "the log does not say its PX4 version (no ver_sw_release); PX4 before "
        f"v{first} applied"
    )
    return (
        f"IMU instance {instance}: {', '.join(names)} not at their defaults; {which} them in "
        "the driver, so sensor_gyro/sensor_accel carry them and so will the model (nothing is "
        "undone); PX4's process_sensor_caldata.py asks for CAL_GYRO*/CAL_ACC* to be reset to "
        "their defaults before a thermal-calibration log"
    )


def _count(scan: _ULogScan, topic: str, multi_id: int) -> int:
    if scan.fallback is not None:
        for d in scan.fallback.data_list:
            if d.name == topic and d.multi_id == multi_id:
                return len(d.data["timestamp"])
        return 0
    return int(
        sum(scan.counts[i] for i, (t, m) in scan.subs.items() if (t, m) == (topic, multi_id))
    )


def _first(scan: _ULogScan, topic: str, multi_id: int) -> dict[str, Any] | None:
    """The first message of a stream, as field -> value (None if there is none)."""
    if scan.fallback is not None:
        arrays = _streams(scan, [(topic, multi_id)])[0]
        return None if arrays is None else {k: v[0] for k, v in arrays.items()}
    ids = [i for i, (t, m) in scan.subs.items() if (t, m) == (topic, multi_id) and scan.counts[i]]
    if not ids or topic not in scan.formats:
        return None
    dtype = _ulog_dtype(scan.formats, topic)
    first = min(_ulog_first(scan.buf, 16, scan.end, i) for i in ids)
    offsets = np.array([first], dtype=np.int64)
    rows = np.empty((1, dtype.itemsize), dtype=np.uint8)
    if _gather(scan.buf, offsets[:1], 5, dtype.itemsize, rows, True) == 0:
        return None
    rec = rows.view(dtype).reshape(1)
    return {n: rec[n][0] for n in dtype.names}


# --------------------------------------------------------------------------- DataFlash

_DF_NUMPY = {
    "b": "i1", "B": "u1", "h": "<i2", "H": "<u2", "i": "<i4", "I": "<u4", "f": "<f4",
    "d": "<f8", "q": "<i8", "Q": "<u8", "n": "S4", "N": "S16", "Z": "S64", "c": "<i2",
    "C": "<u2", "e": "<i4", "E": "<u4", "L": "<i4", "M": "u1", "a": ("<i2", (32,)),
}  # fmt: skip


@dataclass
class _DataFlashScan:
    path: Path
    buf: np.ndarray
    formats: dict[str, Any]  # name -> DFFormat
    offsets: dict[str, np.ndarray]  # name -> message offsets
    notes: list[str]


def _scan_dataflash(p: Path) -> _DataFlashScan:
    _check_magic(
        p, _DF_MAGIC, "DataFlash log", " (a .bin from an ArduPilot SD card or MAVLink download)"
    )
    from pymavlink.DFReader import DFReader_binary

    class IndexOnly(DFReader_binary):  # type: ignore[misc]
        """pymavlink's reader stopped at its message index: its search for a clock parses
        every message in Python when the log has no GPS (most of a minute for an hour)."""

        def init_clock(self) -> None:
            self.clock = None

    try:
        with contextlib.redirect_stdout(_io.StringIO()):
            reader = IndexOnly(str(p))
    except Exception as exc:  # pymavlink raises plain Exceptions on damaged files
        raise LogError(f"{p}: unreadable DataFlash log: {exc}") from None
    buf = _open_buffer(p)
    formats = {f.name: f for f in reader.formats.values()}
    offsets = {}
    for name, f in formats.items():
        offs = np.asarray(reader.offsets[f.type], dtype=np.int64)
        offsets[name] = offs[offs + f.len <= buf.size]
    notes = []
    cut = sum(len(reader.offsets[f.type]) - offsets[n].size for n, f in formats.items())
    if cut:
        notes.append(f"truncated: {cut} cut message(s) at the end are left out")
    reader.close()
    return _DataFlashScan(p, buf, formats, offsets, notes)


def _df_records(scan: _DataFlashScan, name: str) -> np.ndarray | None:
    """Every message ``name`` as numpy records (None when the log has none)."""
    f = scan.formats.get(name)
    if f is None or scan.offsets[name].size == 0:
        return None
    dtype = np.dtype([(c, _DF_NUMPY[ch]) for c, ch in zip(f.columns, f.format, strict=False)])
    if dtype.itemsize != f.len - 3:
        raise LogError(f"{scan.path}: {name} format {f.format!r} does not match its length {f.len}")
    rows = np.empty((scan.offsets[name].size, dtype.itemsize), dtype=np.uint8)
    k = _gather(scan.buf, scan.offsets[name], 3, dtype.itemsize, rows, False)
    return rows[:k].view(dtype).reshape(k)


def _df_imu(scan: _DataFlashScan) -> np.ndarray | None:
    """Every IMU sample as records with the instance field ``I``.

    ArduPilot before 4.0 logged instances 1 and 2 as separate ``IMU2``/``IMU3`` messages
    without ``I``; they are merged here, in time order.
    """
    rec = _df_records(scan, "IMU")
    if rec is None or "I" in rec.dtype.names:
        return rec
    parts = []
    for k, name in enumerate(("IMU", "IMU2", "IMU3")):
        r = rec if k == 0 else _df_records(scan, name)
        if r is not None:
            out = np.zeros(r.size, dtype=np.dtype([*r.dtype.descr, ("I", "u1")]))
            for f in r.dtype.names:
                out[f] = r[f]
            out["I"] = k
            parts.append(out)
    merged = np.concatenate(parts)
    return merged[np.argsort(merged["TimeUS"], kind="stable")]


def _df_params(scan: _DataFlashScan) -> tuple[dict[str, float], list[tuple[float, str, float]]]:
    """Parameters at the start and changes later: (time [s], name, value)."""
    rec = _df_records(scan, "PARM")
    if rec is None:
        return {}, []
    names = [n.split(b"\0")[0].decode("ascii", errors="replace") for n in rec["Name"]]
    times = rec["TimeUS"].astype(np.int64)
    first: dict[str, float] = {}
    changed: list[tuple[float, str, float]] = []
    t0 = int(times.min()) if times.size else 0
    for t, n, v in zip(times, names, rec["Value"].astype(np.float64), strict=True):
        if n not in first:
            first[n] = float(v)
        elif t > t0:
            changed.append((float(t) / 1e6, n, float(v)))
    return first, changed


def _df_counts(scan: _DataFlashScan) -> dict[int, int]:
    """Samples per IMU instance, from the instance byte alone (no decoding of the rest)."""
    f = scan.formats.get("IMU")
    if f is None or scan.offsets["IMU"].size == 0:
        return {}
    if "I" not in f.columns:  # ArduPilot 3.x: IMU, IMU2, IMU3
        names = ("IMU", "IMU2", "IMU3")
        return {k: int(scan.offsets[n].size) for k, n in enumerate(names) if n in scan.offsets}
    k = f.columns.index("I")
    at = 3 + sum(np.dtype(_DF_NUMPY[ch]).itemsize for ch in f.format[:k])
    idx, counts = np.unique(scan.buf[scan.offsets["IMU"] + at], return_counts=True)
    return dict(zip(idx.tolist(), counts.tolist(), strict=True))


_NO_AP_PARAMS = (
    f"ArduPilot has no parameters for IMU instance {{i}} (instances 0 to {ARDUPILOT_IMUS - 1} "
    "only): no correction is known, nothing is undone"
)


def _df_info(scan: _DataFlashScan) -> FlightLogInfo:
    params, changed = _df_params(scan)
    instances = []
    for i, n in _df_counts(scan).items():
        if n == 0:
            continue
        if i >= ARDUPILOT_IMUS:  # not one ArduPilot writes (a damaged record?): no parameters
            instances.append(ImuInstance(i, None, None, n, _NO_AP_PARAMS.format(i=i)))
            continue
        gid = params.get(ardupilot_id_param("gyro", i))
        aid = params.get(ardupilot_id_param("accel", i))
        note = None
        tcal = ardupilot_tcal_prefix(i)
        if ardupilot_tcal_enabled(params, i) or any(
            n_ == f"{tcal}ENABLE" and int(v) == 1 for _, n_, v in changed
        ):
            note = f"{tcal.rstrip('_')} enabled in the log: its correction is undone"
        instances.append(
            ImuInstance(
                i, None if gid is None else int(gid), None if aid is None else int(aid), n, note
            )
        )
    return FlightLogInfo(
        scan.path, "ardupilot", tuple(instances), params, tuple(changed), tuple(scan.notes)
    )


def _in_force(
    params: Mapping[str, float], changed: Sequence[tuple[float, str, float]], t: np.ndarray
) -> list[tuple[slice, dict[str, float]]]:
    """Stretches of the samples (slices of ``t`` [s], sorted) and the parameters in force."""
    out = []
    current = dict(params)
    pending = sorted(changed, key=lambda c: c[0])
    cuts = sorted({c[0] for c in pending})
    edges = [0, *np.searchsorted(t, cuts, side="left").tolist(), t.size]
    k = 0
    for j, (a, b) in enumerate(itertools.pairwise(edges)):
        while j > 0 and k < len(pending) and pending[k][0] <= cuts[j - 1]:
            current[pending[k][1]] = pending[k][2]
            k += 1
        if b > a:
            out.append((slice(a, b), dict(current)))
    return out


def _rotation(orientation: int, p: Path) -> np.ndarray | None:
    """ArduPilot's board rotation ``AHRS_ORIENTATION`` as a matrix (None for none)."""
    if orientation == 0:
        return None
    from pymavlink.rotmat import rotations

    if not 0 <= orientation < len(rotations):
        raise LogError(
            f"{p}: AHRS_ORIENTATION = {orientation} is not a rotation pymavlink knows "
            f"(0..{len(rotations) - 1}); custom orientations cannot be taken out"
        )
    if orientation == 38:  # pymavlink has it as yaw 270; ArduPilot's is pitch 68.8, yaw 293.3
        raise LogError(
            f"{p}: AHRS_ORIENTATION = 38 (roll 90, pitch 68.8, yaw 293.3) cannot be taken out: "
            "pymavlink's table holds another rotation under that number"
        )
    r = rotations[orientation].r
    return np.array([[r.a.x, r.a.y, r.a.z], [r.b.x, r.b.y, r.b.z], [r.c.x, r.c.y, r.c.z]])


# --------------------------------------------------------------------------- frames


#: Share of samples whose time does not increase above which a stream is refused, not cut.
_MAX_OUT_OF_ORDER = 0.01


def _increasing(t: np.ndarray, what: str) -> np.ndarray:
    """Samples whose time is later than every earlier sample's.

    A lone sample stamped far ahead (a glitch) would hide every later one; it is dropped
    first, when it is later than the next sample while its neighbours are in order. More
    than 1 % of the samples out of order is refused (LogError naming ``what``).
    """
    keep = np.ones(t.size, dtype=bool)
    if t.size > 2:  # isolated spikes: t[i] > t[i+1] although t[i-1] < t[i+1]
        spike = (t[1:-1] > t[2:]) & (t[:-2] < t[2:])
        keep[1:-1] = ~spike
    if t.size > 1:
        tk = t[keep]
        ok = np.ones(tk.size, dtype=bool)
        ok[1:] = tk[1:] > np.maximum.accumulate(tk)[:-1]
        keep[np.flatnonzero(keep)[~ok]] = False
    bad = int((~keep).sum())
    if bad > _MAX_OUT_OF_ORDER * t.size:
        first = int(np.flatnonzero(~keep)[0])
        raise LogError(
            f"{what}: {bad} of {t.size} sample times do not increase (first at sample "
            f"{first + 1}, {t[first]} µs after {t[first - 1] if first else 0} µs); the "
            "timestamps are damaged"
        )
    return keep


def _onto(
    t: np.ndarray, ta: np.ndarray, columns: Sequence[np.ndarray], join: str, gap_nan: Sequence[bool]
) -> list[np.ndarray]:
    """Columns sampled at ``ta`` [µs] put on times ``t`` [µs] (inside ``ta``'s span).

    Where ``gap_nan`` is true for a column, samples across a gap (see the module doc) are NaN.
    """
    if t.size == ta.size and np.array_equal(t, ta):  # one chip: the same sample times
        return [np.asarray(c, dtype=np.float64) for c in columns]
    med = float(np.median(np.diff(ta))) if ta.size > 1 else 0.0
    j = np.clip(np.searchsorted(ta, t), 1, max(ta.size - 1, 1))
    lo, hi = ta[j - 1], ta[j]
    if join == "nearest":
        near = np.where(np.abs(lo - t) <= np.abs(hi - t), j - 1, j)
        gap = np.abs(ta[near] - t) > _GAP_NEAREST * med if med > 0 else None
        picked = [np.asarray(c, dtype=np.float64)[near] for c in columns]
    else:
        span = (hi - lo).astype(np.float64)
        w = np.divide((t - lo).astype(np.float64), span, out=np.zeros(t.size), where=span > 0)
        # a sample exactly at an accel time is kept, whatever the gap before it
        gap = ((hi - lo) > _GAP_INTERPOLATE * med) & (t != hi) & (t != lo) if med > 0 else None
        picked = []
        for c in columns:
            c = np.asarray(c, dtype=np.float64)
            picked.append(c[j - 1] + w * (c[j] - c[j - 1]))
    if gap is not None and gap.any():
        for v, g in zip(picked, gap_nan, strict=True):
            if g:
                v[gap] = np.nan
    return picked


def _px4_frame(
    scan: _ULogScan, inst: ImuInstance, join: str, run: str, notes: list[str]
) -> pd.DataFrame:
    p = scan.path
    g, a = _streams(scan, [("sensor_gyro", inst.index), ("sensor_accel", inst.index)])
    label = f"{p}: IMU instance {inst.index}"
    if a is None:
        raise LogError(f"{label}: sensor_gyro is logged but sensor_accel is not; both are needed")
    for topic, d in (("sensor_gyro", g), ("sensor_accel", a)):
        if "temperature" not in d:
            raise LogError(
                f"{label}: {topic} has no temperature field (fields: "
                f"{', '.join(k for k in d if not k.startswith('_'))}); a thermal calibration "
                "needs the sensor's temperature"
            )
        if not np.isfinite(d["temperature"]).any():
            raise LogError(f"{label}: {topic}.temperature is never a number (all NaN)")
    tkey = "timestamp_sample" if "timestamp_sample" in g else "timestamp"
    tg = g[tkey].astype(np.int64)
    ta = a[tkey if tkey in a else "timestamp"].astype(np.int64)
    keep_g = _increasing(tg, f"{label}: sensor_gyro")
    keep_a = _increasing(ta, f"{label}: sensor_accel")
    for topic, keep in (("sensor_gyro", keep_g), ("sensor_accel", keep_a)):
        if not keep.all():
            notes.append(
                f"{label}: {int((~keep).sum())} {topic} sample(s) whose time does not increase "
                "left out"
            )
    for topic, d, keep in (("sensor_gyro", g, keep_g), ("sensor_accel", a, keep_a)):
        unknown = keep & ~np.isfinite(d["temperature"])
        if unknown.any():  # a driver reports NaN before its first temperature reading
            keep &= ~unknown
            notes.append(
                f"{label}: {int(unknown.sum())} {topic} sample(s) without a temperature "
                "(NaN) left out"
            )
    ta = ta[keep_a]
    inside = keep_g & (tg >= ta[0]) & (tg <= ta[-1])
    if (keep_g & ~inside).any():
        notes.append(
            f"{label}: {int((keep_g & ~inside).sum())} gyro sample(s) outside the "
            "accelerometer's time span left out"
        )
    if not inside.any():
        raise LogError(f"{label}: the gyro and accelerometer samples do not overlap in time")
    sel: slice | np.ndarray = inside
    first, last = np.flatnonzero(inside)[[0, -1]]
    if inside[first : last + 1].all():  # the usual case: one stretch, views not copies
        sel = slice(int(first), int(last) + 1)
    if keep_a.all():
        keep_a = slice(None)  # type: ignore[assignment]
    t = tg[sel]
    cols: dict[str, np.ndarray] = {TIME: t / 1e6}
    for c, ax in zip(GYRO_CHANNELS, "xyz", strict=True):
        cols[c] = g[ax][sel]
    *accel, taccel = _onto(
        t,
        ta,
        [a[ax][keep_a] for ax in ("x", "y", "z", "temperature")],
        join,
        (True, True, True, False),
    )
    for c, v in zip(ACCEL_CHANNELS, accel, strict=True):
        cols[c] = v
    tgyro = g["temperature"][sel]
    for c in GYRO_CHANNELS:
        cols[f"temp_{c}"] = tgyro
    for c in ACCEL_CHANNELS:
        cols[f"temp_{c}"] = taccel
    return _frame(cols, run)


def _frame(cols: Mapping[str, np.ndarray], run: str) -> pd.DataFrame:
    """A canonical frame: ``time_s``, ``run``, then the numeric columns as float64.

    The numbers are written once into one column-major block that pandas takes as it is
    (building the frame from separate columns would copy them all again).
    """
    names = list(cols)
    n = len(cols[names[0]])
    block = np.empty((len(names), n))
    for k, name in enumerate(names):
        block[k] = cols[name]
    frame = pd.DataFrame(block.T, columns=names, copy=False)
    frame.insert(1, RUN, run)
    return frame


def _ardupilot_frame(
    info: FlightLogInfo, imu: np.ndarray, inst: ImuInstance, run: str, notes: list[str]
) -> pd.DataFrame:
    p = info.path
    rec = imu[imu["I"] == inst.index]
    if "T" not in rec.dtype.names:
        raise LogError(
            f"{p}: the IMU message has no temperature field T; fields: {rec.dtype.names}"
        )
    us = rec["TimeUS"].astype(np.int64)
    keep = _increasing(us, f"{p}: IMU {inst.index}")
    if not keep.all():
        notes.append(
            f"{p}: IMU {inst.index}: {int((~keep).sum())} sample(s) whose time does not "
            "increase left out"
        )
    rec, us = rec[keep], us[keep]
    t = us / 1e6
    temp = rec["T"].astype(np.float64)
    gyro = np.column_stack([rec[f"Gyr{a}"] for a in "XYZ"]).astype(np.float64)
    accel = np.column_stack([rec[f"Acc{a}"] for a in "XYZ"]).astype(np.float64)
    orientation = int(info.params.get("AHRS_ORIENTATION", 0))
    if any(name == "AHRS_ORIENTATION" for _, name, _v in info.changed):
        notes.append(
            f"AHRS_ORIENTATION changes during the log; the value at the start "
            f"({orientation}) is taken out of every sample"
        )
    rot = _rotation(orientation, p)
    if rot is not None:  # logged in the body frame: v_body = R v_board
        gyro, accel = gyro @ rot, accel @ rot
    if inst.index < ARDUPILOT_IMUS:  # else ArduPilot has no parameters for it (_df_info)
        changes = [c for c in info.changed if ardupilot_tcal_params(c[1], inst.index)]
        for part, params in _in_force(info.params, changes, t):
            gyro[part] += ardupilot_tcal(params, inst.index, "gyro", temp[part])
            accel[part] += ardupilot_tcal(params, inst.index, "accel", temp[part])
    cols: dict[str, np.ndarray] = {TIME: t}
    for j, c in enumerate(GYRO_CHANNELS):
        cols[c] = gyro[:, j]
    for j, c in enumerate(ACCEL_CHANNELS):
        cols[c] = accel[:, j]
    cols[TEMP_IN] = temp
    return _frame(cols, run)


# --------------------------------------------------------------------------- public


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
        :func:`rinscal.io.read_log_source` validates it).

    Raises
    ------
    LogError
        Naming the file and, where it applies, the instance, topic or field.
    """
    info, runs, notes = iter_flight_runs(path, options)
    frames = list(runs)
    frame = frames[0] if len(frames) == 1 else pd.concat(frames, ignore_index=True)
    return FlightLog(info, frame, tuple(notes))
