"""Read a reference track: a table of positions or NMEA GGA sentences, and UTC times.

:func:`read_track` reads ``time_s, ref_lat_deg, ref_lon_deg, ref_h_m`` (and, if there,
``ref_ve_mps, ref_vn_mps, ref_vu_mps``) from a CSV, TSV or Parquet table, or the GGA
sentences of an NMEA file (their UTC times put on the log's
clock by ``utc_start``, :func:`parse_utc`), for ``rinscal navigate --log``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from rinscal.errors import LogError
from rinscal.io.tables import _CSV_READ_KW, _check_parquet, _sniff_text, _text_frames, format_of
from rinscal.schema import (
    _ROWS,
    REF_TRACK,
    REF_VELOCITY,
    TIME,
    as_float,
    check_finite,
    quoted_columns,
)
from rinscal.units import DEG_TO_RAD

__all__ = [
    "Track",
    "parse_utc",
    "read_track",
]


def parse_utc(text: Any, source: str) -> datetime:
    """A timezone-aware UTC datetime from ISO 8601 text (no zone: UTC).

    Raises
    ------
    LogError
        Naming ``source`` when the text is not ISO 8601.
    """
    if isinstance(text, datetime):
        dt = text
    else:
        try:
            dt = datetime.fromisoformat(str(text).strip())
        except ValueError:
            raise LogError(
                f"{source}: {text!r} is not an ISO 8601 date and time (e.g. 2024-05-01T23:59:30Z)"
            ) from None
    return dt.replace(tzinfo=UTC) if dt.tzinfo is None else dt.astimezone(UTC)


def _check_latitude(lat_deg: np.ndarray, source: str, label: str, row: int) -> None:
    with np.errstate(invalid="ignore"):
        bad = np.abs(lat_deg) > 90.0
    if bad.any():
        pos = int(np.argmax(bad))
        raise LogError(
            f"{source}: {label}, data row {row + pos + 1}: latitude {float(lat_deg[pos])!r}° is "
            f"beyond ±90° ({_ROWS})"
        )


@dataclass(frozen=True)
class Track:
    """A reference track read by :func:`read_track`.

    Attributes
    ----------
    t : ndarray, shape (n,) [s]
        Time on the log's clock (``time_s``: seconds since power-on), strictly increasing.
    lat, lon : ndarray, shape (n,) [rad]
        Geodetic latitude and longitude.
    h : ndarray, shape (n,) [m]
        Ellipsoidal height (NMEA: altitude above mean sea level + geoidal separation).
    source : Path
        The file.
    used : int
        Rows (table) or GGA sentences (NMEA) used.
    skipped : dict of str to int
        NMEA lines left out, by reason: ``"checksum"`` (wrong or missing), ``"no_fix"``
        (GGA with fix quality 0 or no position), ``"not_gga"`` (other sentences),
        ``"unparsable"``, ``"repeated_time"`` (a GGA of an epoch already used),
        ``"no_geoid_separation"`` (used, with the altitude taken as the height: counted,
        not left out). Empty for a table.
    v_n : ndarray, shape (n, 3) [m/s], optional
        East, north, up velocity (a table's ``ref_ve_mps, ref_vn_mps, ref_vu_mps``); None:
        positions only (always for NMEA).
    """

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    source: Path
    used: int
    skipped: dict[str, int] = field(default_factory=dict)
    v_n: np.ndarray | None = None


_NMEA_SUFFIXES = (".nmea", ".txt", ".gga", ".log")


def read_track(path: str | os.PathLike[str], utc_start: str | datetime | None = None) -> Track:
    """Read a reference track: a table (CSV, TSV, Parquet) or NMEA GGA sentences.

    Parameters
    ----------
    path : path-like
        A table with ``time_s, ref_lat_deg, ref_lon_deg, ref_h_m`` [s, deg, deg, m],
        optionally ``ref_ve_mps, ref_vn_mps, ref_vu_mps`` [m/s] (all three) (suffix
        ``.csv``, ``.tsv``, ``.parquet``) or NMEA text (suffix ``.nmea``, ``.txt``,
        ``.gga``, ``.log``, or any file whose first line starts with ``$``).
    utc_start : str or datetime, optional
        ISO 8601 UTC of the log's ``time_s`` = 0; needed for NMEA (GGA carries the UTC time
        of day only): ``t = UTC of the sentence − utc_start``, days rolling over midnight.

    Returns
    -------
    Track

    Raises
    ------
    LogError
        Naming the file and the data row (table) or line (NMEA): time not strictly
        increasing, a value that is not finite, a latitude beyond ±90°, no usable position,
        NMEA without ``utc_start``.
    """
    p = Path(path)
    if not p.exists():
        raise LogError(f"{p}: no such file")
    if p.is_dir():
        raise LogError(f"{p}: is a folder, not a track file")
    suffix = p.suffix.lower()
    if suffix in _NMEA_SUFFIXES or (
        suffix not in (".csv", ".tsv", ".parquet", ".pq") and _looks_nmea(p)
    ):
        return _read_nmea(p, utc_start)
    return _read_track_table(p)


def _looks_nmea(p: Path) -> bool:
    with p.open("rb") as fh:
        head = fh.read(4096).lstrip()
    return head.startswith((b"$", b"!"))


def _read_track_table(p: Path) -> Track:
    f = format_of(p)
    if f == "parquet":
        _check_parquet(p)
        # deferred on purpose: pyarrow is heavy and only Parquet needs it
        import pyarrow.parquet as pq

        try:
            df = pq.read_table(p).to_pandas()
        except Exception as exc:
            raise LogError(f"{p}: unreadable Parquet file: {exc}") from None
    else:
        _sniff_text(p)
        options = {
            "sep": "\t" if f == "tsv" else ",",
            "encoding": "utf-8-sig",
            **_CSV_READ_KW,
        }
        df = next(_text_frames(p, options))
    vel = [c for c in REF_VELOCITY if c in df.columns]
    if vel and len(vel) < 3:
        lacking = [c for c in REF_VELOCITY if c not in vel]
        raise LogError(
            f"{p}: velocity column(s) {', '.join(map(repr, vel))} without "
            f"{', '.join(map(repr, lacking))}: a track's velocity needs all three (east, "
            "north, up [m/s])"
        )
    want = (TIME, *REF_TRACK)
    missing = [c for c in want if c not in df.columns]
    if missing:
        raise LogError(
            f"{p}: track column(s) {', '.join(map(repr, missing))} missing (columns found: "
            f"{quoted_columns([str(c) for c in df.columns])}); a track table has "
            f"{', '.join(want)}"
        )
    if len(df) < 1:
        raise LogError(f"{p}: no data rows (only a header)")
    arrays = {}
    for c in (*want, *vel):
        x = as_float(df[c], str(p), c)
        check_finite(x, str(p), c, None, False, "a track value must be finite")
        arrays[c] = x
    _check_latitude(arrays[REF_TRACK[0]], str(p), f"column {REF_TRACK[0]!r}", 0)
    t = arrays[TIME]
    bad = np.diff(t) <= 0
    if bad.any():
        k = int(np.argmax(bad)) + 1
        raise LogError(
            f"{p}: column {TIME!r}, data row {k + 1}: time not strictly increasing "
            f"({t[k]:.10g} s after {t[k - 1]:.10g} s) ({_ROWS})"
        )
    return Track(
        t=t,
        lat=arrays[REF_TRACK[0]] * DEG_TO_RAD,
        lon=arrays[REF_TRACK[1]] * DEG_TO_RAD,
        h=arrays[REF_TRACK[2]],
        source=p,
        used=len(t),
        v_n=np.column_stack([arrays[c] for c in REF_VELOCITY]) if vel else None,
    )


def _read_nmea(p: Path, utc_start: str | datetime | None) -> Track:
    # deferred on purpose: pynmea2 is needed only for an NMEA track
    import pynmea2

    if utc_start is None:
        raise LogError(
            f"{p}: NMEA GGA sentences carry the UTC time of day only: pass track_utc_start= "
            "(ISO 8601 UTC of the log's time_s = 0) or put utc_start in the log's metadata"
        )
    start = parse_utc(utc_start, f"{p}: utc_start")
    start_tod = (start - start.replace(hour=0, minute=0, second=0, microsecond=0)).total_seconds()
    skipped = dict.fromkeys(
        ("checksum", "no_fix", "not_gga", "unparsable", "repeated_time", "no_geoid_separation"), 0
    )
    t: list[float] = []
    lat: list[float] = []
    lon: list[float] = []
    h: list[float] = []
    day = 0
    prev_tod: float | None = None
    try:
        text = p.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise LogError(f"{p}: cannot read: {exc}") from None
    for lineno, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s:
            continue
        k = s.find("$")
        if k < 0:
            skipped["unparsable"] += 1
            continue
        s = s[k:]
        try:
            msg = pynmea2.parse(s, check=True)
        except pynmea2.ChecksumError:
            skipped["checksum"] += 1
            continue
        except (pynmea2.ParseError, ValueError, TypeError, AttributeError):
            skipped["unparsable"] += 1
            continue
        if getattr(msg, "sentence_type", None) != "GGA":
            skipped["not_gga"] += 1
            continue
        try:
            qual = int(msg.gps_qual or 0)
            stamp = msg.timestamp
            la, lo = float(msg.latitude), float(msg.longitude)
            alt = float(msg.altitude) if msg.altitude not in (None, "") else None
            sep_text = msg.geo_sep
        except (TypeError, ValueError, AttributeError):
            skipped["unparsable"] += 1
            continue
        if qual <= 0 or alt is None or not msg.lat or not msg.lon or stamp is None:
            skipped["no_fix"] += 1
            continue
        if abs(la) > 90.0 or not (math.isfinite(la) and math.isfinite(lo) and math.isfinite(alt)):
            raise LogError(f"{p}: line {lineno}: latitude {la!r}° is beyond ±90° or not finite")
        try:
            geo_sep = float(sep_text) if sep_text not in (None, "") else None
        except ValueError:
            geo_sep = None
        if geo_sep is None:
            skipped["no_geoid_separation"] += 1
            geo_sep = 0.0
        tod = stamp.hour * 3600.0 + stamp.minute * 60.0 + stamp.second + stamp.microsecond * 1e-6
        if prev_tod is None:
            if tod - start_tod < -43200.0:  # started before midnight, first fix after it
                day = 1
        elif tod < prev_tod - 43200.0:  # midnight
            day += 1
        elif tod < prev_tod:
            raise LogError(
                f"{p}: line {lineno}: GGA time {stamp} before the previous one; NMEA lines "
                "must be in time order"
            )
        if prev_tod is not None and tod == prev_tod:
            skipped["repeated_time"] += 1
            continue
        prev_tod = tod
        t.append(day * 86400.0 + tod - start_tod)
        lat.append(la)
        lon.append(lo)
        h.append(alt + geo_sep)
    if not t:
        raise LogError(
            f"{p}: no GGA sentence with a fix (skipped: "
            f"{', '.join(f'{k} {v}' for k, v in skipped.items() if v) or 'none'})"
        )
    return Track(
        t=np.asarray(t),
        lat=np.asarray(lat) * DEG_TO_RAD,
        lon=np.asarray(lon) * DEG_TO_RAD,
        h=np.asarray(h),
        source=p,
        used=len(t),
        skipped={k: v for k, v in skipped.items() if v},
    )
