"""Read an ArduPilot DataFlash log (``.bin``): index it, decode ``IMU`` and ``PARM`` records.

``pymavlink`` indexes the messages (``DFReader_binary``'s offsets per message type); the
``IMU``/``PARM`` messages are decoded as numpy records. The board rotation and an active
``INS_TCAL`` correction are undone (see :mod:`rinscal.io.flightlog`).
"""

from __future__ import annotations

import contextlib
import io as _io
import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rinscal.errors import LogError
from rinscal.firmware import (
    ARDUPILOT_IMUS,
    ardupilot_id_param,
    ardupilot_tcal,
    ardupilot_tcal_enabled,
    ardupilot_tcal_params,
    ardupilot_tcal_prefix,
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
from rinscal.schema import ACCEL_CHANNELS, GYRO_CHANNELS, TEMP_IN, TIME

__all__: list[str] = []

_DF_MAGIC = b"\xa3\x95\x80"

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
    # deferred on purpose: pymavlink is heavy, loaded only when a DataFlash log is read
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
    # deferred on purpose: pymavlink is heavy, loaded only when a DataFlash log is read
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
