"""Read a PX4 ULog (``.ulg``): scan its definitions and data, join gyro and accelerometer.

``pyulog`` parses the definitions (formats, parameters, info); the data section is walked by
compiled scanners that copy only the ``sensor_gyro``/``sensor_accel`` messages (see
:mod:`rinscal.io.flightlog` for what is read and why). A log the scanners cannot walk is
read by ``pyulog`` itself.
"""

from __future__ import annotations

import contextlib
import errno
import io as _io
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numba
import numpy as np
import pandas as pd

from rinscal.errors import LogError, describe_os_error
from rinscal.firmware import (
    PX4_RAW_DRIVERS_FROM,
    px4_driver_calibration,
    px4_tc_slot,
)
from rinscal.io._gather import _gather
from rinscal.io.flightinfo import (
    FlightLogInfo,
    ImuInstance,
    _check_magic,
    _frame,
    _increasing,
    _open_buffer,
)
from rinscal.schema import ACCEL_CHANNELS, GYRO_CHANNELS, TIME
from rinscal.units import US_TO_S

__all__: list[str] = []

_ULOG_MAGIC = b"ULog\x01\x12\x35"
#: ULog message types (A B C F I L M O P Q R S; D is handled apart).
_KNOWN = np.zeros(256, dtype=np.bool_)
_KNOWN[np.frombuffer(b"ABCFILMOPQRS", dtype=np.uint8)] = True
_GAP_INTERPOLATE = 3.0  # accel gap (in median intervals) across which no value is made up
_GAP_NEAREST = 1.5


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


def _pyulog(p: Path, damage: str | None = None, **kw: Any) -> Any:
    """pyulog's ULog of ``p`` (what it prints about a damaged file is kept off the terminal:
    the reader's notes say what was done). ``damage``: what the scanner found wrong, named
    when pyulog cannot read past it either."""
    # deferred on purpose: pyulog is heavy, loaded only when a ULog is read
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


def _onto(
    t: np.ndarray, ta: np.ndarray, columns: Sequence[np.ndarray], join: str, gap_nan: Sequence[bool]
) -> list[np.ndarray]:
    """Columns sampled at ``ta`` [µs] put on times ``t`` [µs] (inside ``ta``'s span).

    Where ``gap_nan`` is true for a column, samples across a gap (see the doc of
    :mod:`rinscal.io.flightlog`) are NaN.
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
