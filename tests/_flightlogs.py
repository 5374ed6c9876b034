"""Writers of PX4 ULog and ArduPilot DataFlash logs for the tests, from the formats' own docs.

Written from the published descriptions, not from the readers under test:

ULog (docs.px4.io, "ULog File Format")
    16-byte header ``ULog`` ``01 12 35`` + version byte + uint64 start time [µs]; then
    messages of ``uint16 msg_size`` (payload bytes), ``uint8 msg_type``, payload. Definitions:
    ``B`` flag bits (8 compat + 8 incompat bytes + 3 uint64 appended offsets), ``I`` info and
    ``P`` parameter (``uint8 key_len``, key ``"<type> <name>"``, value bytes), ``F`` format
    (``"name:type field;type field;..."``). Data section: ``A`` subscription
    (``uint8 multi_id``, ``uint16 msg_id``, name), ``D`` data (``uint16 msg_id``, the fields
    packed as the format lists them), ``P`` a parameter changed while logging.
DataFlash (ardupilot.org, "Downloading and Analyzing Data Logs"; ``LogStructure.h``)
    Every message: ``0xA3 0x95``, a type byte, the fields packed little-endian. Type 128
    ``FMT`` (``BBnNZ``: Type, Length incl. the 3 header bytes, Name[4], Format[16],
    Columns[64]) defines the others, itself included. ``PARM`` ``QNff`` (TimeUS, Name[16],
    Value, Default); ``IMU`` ``QBffffffIIfBBHH`` (TimeUS, I, GyrX..Z [rad/s], AccX..Z
    [m/s²], EG, EA, T [°C], GH, AH, GHz, AHz).

Messages of all streams are interleaved in time order, as a logger writes them. Numpy builds
every message at once, so a one-hour 1 kHz log takes seconds to write.
"""

from __future__ import annotations

import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

_C_TYPES = {
    "int8_t": "i1",
    "uint8_t": "u1",
    "int16_t": "<i2",
    "uint16_t": "<u2",
    "int32_t": "<i4",
    "uint32_t": "<u4",
    "int64_t": "<i8",
    "uint64_t": "<u8",
    "float": "<f4",
    "double": "<f8",
    "bool": "u1",
    "char": "S1",
}

#: PX4's sensor_gyro and sensor_accel fields (msg/SensorGyro.msg, SensorAccel.msg), packed.
GYRO_FIELDS: tuple[tuple[str, str], ...] = (
    ("uint64_t", "timestamp"),
    ("uint64_t", "timestamp_sample"),
    ("uint32_t", "device_id"),
    ("float", "x"),
    ("float", "y"),
    ("float", "z"),
    ("float", "temperature"),
    ("uint32_t", "error_count"),
)
ACCEL_FIELDS: tuple[tuple[str, str], ...] = (
    *GYRO_FIELDS,
    ("uint8_t[3]", "clip_counter"),
    ("uint8_t[5]", "_padding0"),
)


@dataclass
class Topic:
    """One logged stream of a ULog: a uORB topic instance and its samples.

    ``data`` maps each field name to its values (arrays of the same length; an array field
    ``uint8_t[3]`` takes shape (n, 3); fields left out are zero). Messages are ordered by the
    ``timestamp`` field.
    """

    name: str
    multi_id: int
    fields: Sequence[tuple[str, str]]
    data: Mapping[str, np.ndarray]


def _field_dtype(ctype: str) -> tuple[str, tuple[int, ...]]:
    if "[" in ctype:
        base, n = ctype.rstrip("]").split("[")
        return _C_TYPES[base], (int(n),)
    return _C_TYPES[ctype], ()


def _records(
    fields: Sequence[tuple[str, str]], n: int, head: Sequence[tuple[str, str]]
) -> np.ndarray:
    dt = [(name, code) for name, code in head]
    for ctype, name in fields:
        code, shape = _field_dtype(ctype)
        dt.append((name, code, shape) if shape else (name, code))
    return np.zeros(n, dtype=np.dtype(dt))  # packed: numpy adds no padding without align=True


def _merge(streams: list[tuple[np.ndarray, np.ndarray]], out: object, chunk: int = 1 << 18) -> None:
    """Write the records of several streams to ``out`` in time order (stable across streams).

    Each stream is ``(times, records)``; records of a stream all have one size.
    """
    times = np.concatenate([t for t, _ in streams])
    which = np.concatenate([np.full(len(t), k, dtype=np.int32) for k, (t, _) in enumerate(streams)])
    index = np.concatenate([np.arange(len(t), dtype=np.int64) for t, _ in streams])
    order = np.lexsort((which, times))
    raw = [r.view(np.uint8).reshape(len(r), -1) for _, r in streams]
    sizes = np.array([r.shape[1] for r in raw], dtype=np.int64)
    for a in range(0, order.size, chunk):
        sel = order[a : a + chunk]
        w, i = which[sel], index[sel]
        length = sizes[w]
        offsets = np.concatenate([[0], np.cumsum(length)[:-1]])
        buf = np.empty(int(length.sum()), dtype=np.uint8)
        for k, rows in enumerate(raw):
            m = w == k
            if m.any():
                pos = offsets[m][:, None] + np.arange(rows.shape[1])
                buf[pos] = rows[i[m]]
        out.write(buf.tobytes())  # type: ignore[attr-defined]


def _cut(path: Path, cut_bytes: int) -> Path:
    """Drop ``cut_bytes`` from the end of a file (a truncated log)."""
    if cut_bytes:
        with path.open("r+b") as fh:
            fh.truncate(path.stat().st_size - cut_bytes)
    return path


def _msg(kind: bytes, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), kind[0]) + payload


def _key_value(name: str, value: int | float | str) -> bytes:
    if isinstance(value, str):
        raw = value.encode()
        key = f"char[{len(raw)}] {name}".encode()
    elif isinstance(value, int) and not isinstance(value, bool):
        key, raw = f"int32_t {name}".encode(), struct.pack("<i", value)
    else:
        key, raw = f"float {name}".encode(), struct.pack("<f", value)
    return struct.pack("<B", len(key)) + key + raw


def write_ulog(
    path: str | Path,
    topics: Sequence[Topic],
    params: Mapping[str, int | float] | None = None,
    changed: Sequence[tuple[int, str, int | float]] = (),
    info: Mapping[str, str | int] | None = None,
    start_us: int = 0,
    cut_bytes: int = 0,
) -> Path:
    """Write a ULog (version 1) with the given topics, parameters and info.

    Parameters
    ----------
    topics : sequence of Topic
        The streams; ``data["timestamp"]`` [µs] orders the messages.
    params : mapping, optional
        Initial parameters (int -> ``int32_t``, float -> ``float``).
    changed : sequence of (time [µs], name, value)
        Parameters changed while logging, written among the data at their time.
    info : mapping, optional
        Info messages (``sys_name`` etc.; an int is written as ``int32_t``, e.g.
        ``ver_sw_release``).
    cut_bytes : int
        Drop this many bytes from the end (a truncated log).
    """
    path = Path(path)
    with path.open("wb") as out:
        out.write(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", start_us))
        out.write(_msg(b"B", bytes(16) + struct.pack("<3Q", 0, 0, 0)))
        for k, v in (info or {"sys_name": "PX4", "ver_hw": "RINSCAL_TEST"}).items():
            out.write(_msg(b"I", _key_value(k, v)))
        names: dict[str, Sequence[tuple[str, str]]] = {}
        for t in topics:
            names.setdefault(t.name, t.fields)
        for name, fields in names.items():
            text = name + ":" + "".join(f"{ctype} {fname};" for ctype, fname in fields)
            out.write(_msg(b"F", text.encode()))
        for k, v in (params or {}).items():
            out.write(_msg(b"P", _key_value(k, v)))
        for msg_id, t in enumerate(topics):
            out.write(_msg(b"A", struct.pack("<BH", t.multi_id, msg_id) + t.name.encode()))
        streams: list[tuple[np.ndarray, np.ndarray]] = []
        for msg_id, t in enumerate(topics):
            n = len(t.data["timestamp"])
            written = list(t.fields)
            while written and written[-1][1].startswith("_padding"):
                written.pop()  # PX4's logger leaves out trailing padding (o_size_no_padding)
            rec = _records(written, n, (("size", "<u2"), ("type", "u1"), ("msg_id", "<u2")))
            rec["size"] = rec.dtype.itemsize - 3
            rec["type"] = ord("D")
            rec["msg_id"] = msg_id
            for fname, values in t.data.items():
                rec[fname] = values
            streams.append((np.asarray(t.data["timestamp"], dtype=np.int64), rec))
        for when, name, value in changed:
            body = np.frombuffer(_msg(b"P", _key_value(name, value)), dtype=np.uint8)
            rec = body.view(np.dtype((np.void, body.size)))
            streams.append((np.array([when], dtype=np.int64), rec.copy()))
        _merge(streams, out)
    return _cut(path, cut_bytes)


def ulog_data_start(raw: bytes) -> int:
    """Byte offset of a ULog's data section: its first subscription (``A``) message."""
    pos = 16
    while raw[pos + 2] != ord("A"):
        pos += 3 + struct.unpack_from("<H", raw, pos)[0]
    return pos


def _sensor(
    us: np.ndarray, delay_us: int, device_id: int, values: np.ndarray, temp: np.ndarray
) -> dict[str, np.ndarray]:
    """Fields of one sensor topic: sampled at ``us``, published ``delay_us`` later."""
    return {
        "timestamp": us + delay_us,
        "timestamp_sample": us,
        "device_id": np.full(us.size, device_id, dtype=np.uint32),
        "x": values[:, 0],
        "y": values[:, 1],
        "z": values[:, 2],
        "temperature": temp,
    }


def px4_topics(
    time_s: np.ndarray,
    gyro: np.ndarray,
    accel: np.ndarray,
    temp: np.ndarray,
    instance: int,
    gyro_id: int,
    accel_id: int,
    accel_time_s: np.ndarray | None = None,
    accel_values: np.ndarray | None = None,
    accel_temp: np.ndarray | None = None,
) -> list[Topic]:
    """``sensor_gyro`` and ``sensor_accel`` of one instance (SI units, time [s] since boot).

    By default the accelerometer is sampled with the gyro; ``accel_time_s`` (with
    ``accel_values`` and ``accel_temp``) gives it its own sample times.
    """
    us = np.round(time_s * 1e6).astype(np.int64)
    g = _sensor(us, 150, gyro_id, gyro, temp)
    if accel_time_s is None:
        a = _sensor(us, 160, accel_id, accel, temp)
    else:
        a_us = np.round(accel_time_s * 1e6).astype(np.int64)
        a = _sensor(a_us, 160, accel_id, accel_values, accel_temp)  # type: ignore[arg-type]
    return [
        Topic("sensor_gyro", instance, GYRO_FIELDS, g),
        Topic("sensor_accel", instance, ACCEL_FIELDS, a),
    ]


# ----------------------------------------------------------------------------- DataFlash

_DF_HEAD = b"\xa3\x95"
_DF_FMT = 128
_DF_CODES = {
    "B": "u1", "b": "i1", "H": "<u2", "h": "<i2", "I": "<u4", "i": "<i4", "Q": "<u8",
    "q": "<i8", "f": "<f4", "d": "<f8", "n": "S4", "N": "S16", "Z": "S64",
}  # fmt: skip


@dataclass
class DataFlashImu:
    """One ArduPilot IMU instance: time [s] since boot, gyro [rad/s], accel [m/s²], T [°C]."""

    instance: int
    time_s: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    temp: np.ndarray
    extra: dict[str, np.ndarray] = field(default_factory=dict)


def _df_dtype(fmt: str, columns: str) -> np.dtype:
    cols = columns.split(",")
    return np.dtype(
        [("head", "S2"), ("type", "u1")]
        + [(c, _DF_CODES[f]) for f, c in zip(fmt, cols, strict=True)]
    )


def _df_fmt(msg_type: int, name: str, fmt: str, columns: str) -> bytes:
    length = _df_dtype(fmt, columns).itemsize
    return _DF_HEAD + struct.pack(
        "<BBB4s16s64s",
        _DF_FMT,
        msg_type,
        length,
        name.encode(),
        fmt.encode(),
        columns.encode(),
    )


_PARM = (64, "PARM", "QNff", "TimeUS,Name,Value,Default")
_IMU = (
    65,
    "IMU",
    "QBffffffIIfBBHH",
    "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz",
)


def write_dataflash(
    path: str | Path,
    imus: Sequence[DataFlashImu],
    params: Mapping[str, float] | None = None,
    changed: Sequence[tuple[int, str, float]] = (),
    cut_bytes: int = 0,
    legacy: bool = False,
) -> Path:
    """Write an ArduPilot DataFlash (``.bin``) log: FMT, PARM at boot and later, IMU data.

    ``params`` are logged at time 0 (as ArduPilot logs every parameter at the start),
    ``changed`` at their time [µs]. ``legacy``: as ArduPilot 3.x, instances 1 and 2 as their
    own ``IMU2``/``IMU3`` messages, without the instance field ``I``.
    """
    path = Path(path)
    imu_formats = [_IMU]
    if legacy:
        fmt, cols = _IMU[2].replace("QB", "Q", 1), _IMU[3].replace(",I,", ",", 1)
        imu_formats = [(65 + k, ("IMU", "IMU2", "IMU3")[k], fmt, cols) for k in range(3)]
    with path.open("wb") as out:
        out.write(_df_fmt(_DF_FMT, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns"))
        for msg_type, name, fmt, cols in (_PARM, *imu_formats):
            out.write(_df_fmt(msg_type, name, fmt, cols))
        parm_dt = _df_dtype(_PARM[2], _PARM[3])
        entries = [(0, k, v) for k, v in (params or {}).items()] + list(changed)
        streams: list[tuple[np.ndarray, np.ndarray]] = []
        if entries:
            p = np.zeros(len(entries), dtype=parm_dt)
            p["head"], p["type"] = _DF_HEAD, _PARM[0]
            p["TimeUS"] = [e[0] for e in entries]
            p["Name"] = [e[1].encode() for e in entries]
            p["Value"] = [e[2] for e in entries]
            streams.append((p["TimeUS"].astype(np.int64), p))
        for imu in imus:
            msg_type, _, fmt, cols = imu_formats[imu.instance if legacy else 0]
            rec = np.zeros(imu.time_s.size, dtype=_df_dtype(fmt, cols))
            rec["head"], rec["type"] = _DF_HEAD, msg_type
            if not legacy:
                rec["I"] = imu.instance
            rec["TimeUS"] = np.round(imu.time_s * 1e6).astype(np.uint64)
            for j, ax in enumerate("XYZ"):
                rec[f"Gyr{ax}"] = imu.gyro[:, j]
                rec[f"Acc{ax}"] = imu.accel[:, j]
            rec["T"] = imu.temp
            rec["GH"] = rec["AH"] = 1
            for k, v in imu.extra.items():
                rec[k] = v
            streams.append((rec["TimeUS"].astype(np.int64), rec))
        _merge(streams, out)
    return _cut(path, cut_bytes)
