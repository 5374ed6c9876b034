"""Open a recorded-navigation log (``rinscal navigate --log``): its header, mapping, metadata
and units resolved.

:func:`open_nav_log` reads the header (and the sidecar metadata, :mod:`rinscal.io.metadata`),
finds which columns hold what and returns a :class:`rinscal.io.navlog.NavLog` that reads the
samples piece by piece.

A recording (CSV, TSV or Parquet, one row per IMU sample, see the "navigation log" section
of :mod:`rinscal.schema`) is read in pieces of about
:data:`rinscal.io.streaming.PIECE_ROWS` rows, never whole: only the columns it needs (Parquet
record batches, CSV/TSV chunks), each piece turned into a :class:`rinscal.schema.NavSamples`
of angle and velocity increments [rad, m/s] in the IMU frame r (right-forward-up), time in
seconds.

The IMU's output may be written as

* **rates** ``gyro_*``, ``accel_*``: the mean rate over the interval ending at ``time_s``
  in the declared units (deg/h and µg by default; rad/s, deg/s, m/s², mg, g allowed);
  ``dtheta = rate · dt``, ``dt[k] = t[k] − t[k−1]``, the first sample's ``dt`` the nominal
  interval (``rate_hz`` of the metadata, else the median interval of the first 1001
  samples);
* **increments** ``dtheta_*`` [rad], ``dvel_*`` [m/s] over the interval ending at ``time_s``,
  taken as they are;
* **integer counts** per interval (in columns mapped onto either naming) times a pulse
  weight given in the mapping's ``[weights]``.

A foreign file is read through the one mapping of every foreign log,
:class:`rinscal.io.mapping.ColumnMapping` (its TOML format, ``weights``, ``axes``, the
encoder's ``table_*`` keys and ``select_run`` are described there), read with
``read_mapping(path, log_kind="navigation")``, never by editing the file. A file whose columns
already have the canonical names needs no mapping; columns that are neither canonical nor
mapped are never read.

Sidecar metadata ``<log>.meta.json`` (:func:`rinscal.io.metadata.read_meta`) may give ``rate_hz``,
``units`` (of rate columns), ``site`` = ``{"lat_deg", "lon_deg", "h_m"}``, ``heading_deg``,
``noise`` = ``{"gyro_noise_density" [rad/√s], "accel_noise_density" [m/s²/√Hz]}`` (and
optionally ``"gyro_bias_rw"`` [rad/s/√s], ``"accel_bias_rw"`` [m/s²/√s], and the turn-on
repeatability ``"gyro_turn_on"`` [rad/s], ``"accel_turn_on"`` [m/s²], 1σ) and
``utc_start`` (ISO 8601, the UTC of ``time_s`` = 0, for NMEA reference tracks).

A reference track may also be a separate file, read by
:func:`rinscal.io.track.read_track`: a table with ``time_s, ref_lat_deg, ref_lon_deg,
ref_h_m`` or NMEA GGA sentences.

Row numbers in messages are data rows of the file: 1-based, the header not counted.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from rinscal.errors import ConfigError, LogError
from rinscal.io.mapping import SEPARATORS, ColumnMapping, channel_unit, check_applies, parse_weight
from rinscal.io.metadata import read_meta
from rinscal.io.navlog import Kind, NavLog
from rinscal.io.tables import Format, _check_parquet, _sniff_text, format_of
from rinscal.io.track import parse_utc
from rinscal.schema import (
    CHAMBER,
    CHANNELS,
    DTHETA,
    DVEL,
    NAV_CANONICAL,
    NAV_RATES,
    REF_HEADING,
    REF_TRACK,
    RUN,
    TABLE,
    TEMP_CHANNELS,
    TEMP_IN,
    TEMP_OUT,
    TIME,
    quoted_columns,
)
from rinscal.units import DEG_TO_RAD, SENSOR_UNITS, check_sensor_unit

__all__ = [
    "DEFAULT_RATE_UNITS",
    "NavHeader",
    "nav_log_header",
    "open_nav_log",
]

#: Default units of rate columns when neither the mapping nor the metadata says.
DEFAULT_RATE_UNITS: dict[str, str] = {"gyro": "deg/h", "accel": "ug"}


def _header(
    p: Path, fmt: str, mapping: ColumnMapping | None
) -> tuple[list[str], str | None, int | None]:
    """The file's column names, its separator (text) and its row count (Parquet); a mapping
    with keys of a calibration log refused (ConfigError)."""
    if mapping is not None:
        check_applies(mapping, "navigation")
    if fmt == "parquet":
        # deferred on purpose: pyarrow is heavy and only Parquet needs it
        import pyarrow.parquet as pq

        _check_parquet(p)
        try:
            pf = pq.ParquetFile(p)
        except Exception as exc:  # pyarrow raises many types for a damaged file
            raise LogError(f"{p}: unreadable Parquet file: {exc}") from None
        names = [n for n in pf.schema_arrow.names if not n.startswith("__index_level_")]
        return names, None, int(pf.metadata.num_rows)
    header = _sniff_text(p)
    name = mapping.separator if mapping is not None else None
    if name is None:
        sep = "\t" if fmt == "tsv" else ","
    else:
        sep = SEPARATORS[name]
        if sep is None:
            counts = {s: header.count(s) for s in ("\t", ",", ";")}
            sep = max(counts, key=counts.__getitem__)
            if counts[sep] == 0:
                raise LogError(f"{p}: cannot guess the separator: header has no tab, comma or ';'")
    cols = next(csv.reader([header], delimiter=sep), [])
    dup = sorted({c for c in cols if cols.count(c) > 1})
    if dup:
        raise LogError(
            f"{p}: column(s) {', '.join(map(repr, dup))} appear more than once in the header"
        )
    if len(cols) < 2:
        seps = {"\t": "tab", ",": "comma", ";": "semicolon"}
        found = [nm for s, nm in seps.items() if s != sep and s in header]
        hint = f" (the header contains a {found[0]}: set the separator)" if found else ""
        raise LogError(
            f"{p}: not a table: only one column {header[:60]!r} with "
            f"{seps.get(sep, repr(sep))} separation{hint}"
        )
    return cols, sep, None


def _resolve(p: Path, cols: list[str], mapping: ColumnMapping | None) -> dict[str, str]:
    """Canonical name -> the file's column, for every canonical column the file has."""
    names = {c: c for c in cols if c in NAV_CANONICAL}
    if mapping is None:
        return names
    rename = mapping.rename()
    missing = [c for c in rename if c not in cols]
    if missing:
        raise LogError(
            f"{p}: column(s) {', '.join(map(repr, missing))} named in the mapping are not in "
            f"the file (columns found: {quoted_columns(cols)})"
        )
    clash = [c for c in rename.values() if c in names and c not in rename]
    if clash:
        raise LogError(
            f"{p}: the mapping renames other columns to {', '.join(map(repr, clash))}, which "
            "the file already has; map only one of them"
        )
    for foreign, canon in rename.items():
        names.pop(foreign, None)  # a canonical-named column mapped onto another name
        names[canon] = foreign
    return names


def _kind(
    p: Path,
    names: dict[str, str],
    mapping: ColumnMapping | None,
    cols: list[str],
    meta_weights: bool = False,
) -> tuple[Kind, tuple[str, ...]]:
    """How the file gives the IMU's output, and its six sensor columns (canonical names);
    ``meta_weights``: the metadata gives pulse weights (increment columns are counts)."""
    rates = [c for c in NAV_RATES if c in names]
    incr = [c for c in (*DTHETA, *DVEL) if c in names]

    def shown(cs: list[str]) -> str:
        return ", ".join(repr(names[c]) if names[c] == c else f"{names[c]!r} ({c})" for c in cs)

    if rates and incr:
        raise LogError(
            f"{p}: both rates ({shown(rates)}) and increments ({shown(incr)}): a log gives "
            "the IMU's output one way; map only one kind of column"
        )
    if not rates and not incr:
        raise LogError(
            f"{p}: no IMU output columns: need rates {', '.join(NAV_RATES)} or increments "
            f"{', '.join((*DTHETA, *DVEL))} (columns found: {quoted_columns(cols)}); a foreign log "
            "needs a mapping"
        )
    want = NAV_RATES if rates else (*DTHETA, *DVEL)
    have = rates or incr
    if len(have) < 6:
        lacking = [c for c in want if c not in names]
        raise LogError(
            f"{p}: {'rate' if rates else 'increment'} columns {shown(have)} but not "
            f"{', '.join(map(repr, lacking))}: all six are needed"
        )
    if (mapping is not None and mapping.weights) or (meta_weights and incr):
        return "counts", tuple(want)
    if incr and mapping is not None and mapping.units:
        raise ConfigError(
            f"{p}: the mapping gives [units], but the file holds increments ({shown(incr)}) "
            "in rad and m/s; [units] are for rate columns (gyro_*, accel_*), [weights] for counts"
        )
    return ("rates" if rates else "increments"), tuple(want)


def _meta_number(meta: Mapping[str, Any], key: str, mp: str, positive: bool = False) -> float:
    v = meta[key]
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise LogError(f"{mp}: {key}: {v!r} is not a finite number")
    if positive and v <= 0:
        raise LogError(f"{mp}: {key}: {v!r} must be positive")
    return float(v)


def _read_meta_fields(meta: dict[str, Any] | None, mp: str) -> dict[str, Any]:
    out: dict[str, Any] = {
        "rate_hz": None, "site": None, "heading_deg": None, "noise": None, "utc_start": None,
    }  # fmt: skip
    if not meta:
        return out
    if "rate_hz" in meta:
        out["rate_hz"] = _meta_number(meta, "rate_hz", mp, positive=True)
    if "site" in meta:
        site = meta["site"]
        if not isinstance(site, Mapping) or "lat_deg" not in site or "lon_deg" not in site:
            raise LogError(f'{mp}: site must be {{"lat_deg": ..., "lon_deg": ..., "h_m": ...}}')
        lat = _meta_number(site, "lat_deg", f"{mp}: site")
        lon = _meta_number(site, "lon_deg", f"{mp}: site")
        h = _meta_number(site, "h_m", f"{mp}: site") if "h_m" in site else 0.0
        if abs(lat) > 90.0:
            raise LogError(f"{mp}: site.lat_deg: {lat!r} is beyond ±90°")
        out["site"] = (lat * DEG_TO_RAD, lon * DEG_TO_RAD, h)
    elif "latitude_deg" in meta:  # a calibration log's metadata: latitude, altitude
        lat = _meta_number(meta, "latitude_deg", mp)
        if abs(lat) > 90.0:
            raise LogError(f"{mp}: latitude_deg: {lat!r} is beyond ±90°")
        lon = _meta_number(meta, "longitude_deg", mp) if "longitude_deg" in meta else 0.0
        h = _meta_number(meta, "altitude_m", mp) if "altitude_m" in meta else 0.0
        out["site"] = (lat * DEG_TO_RAD, lon * DEG_TO_RAD, h)
    if meta.get("heading_deg") is not None:
        out["heading_deg"] = _meta_number(meta, "heading_deg", mp)
    if "noise" in meta:
        noise = meta["noise"]
        if not isinstance(noise, Mapping):
            raise LogError(f"{mp}: noise must be an object of noise densities")
        out["noise"] = {
            k: _meta_number(noise, k, f"{mp}: noise")
            for k in (
                "gyro_noise_density",
                "accel_noise_density",
                "gyro_bias_rw",
                "accel_bias_rw",
                "gyro_angle_noise",
                "accel_velocity_noise",
                "gyro_turn_on",
                "accel_turn_on",
            )
            if k in noise
        }
        for k, v in out["noise"].items():
            if v < 0:
                raise LogError(f"{mp}: noise.{k}: {v!r} is negative")
    if meta.get("utc_start") is not None:
        out["utc_start"] = parse_utc(meta["utc_start"], f"{mp}: utc_start")
    return out


def _units(
    kind: Kind, mapping: ColumnMapping | None, meta: dict[str, Any] | None, mp: str
) -> tuple[dict[str, str], dict[str, float]]:
    units: dict[str, str] = {}
    to_si: dict[str, float] = {}
    meta_units = (meta or {}).get("units") or {}
    if not isinstance(meta_units, Mapping):
        raise LogError(f"{mp}: units must be an object of unit names")
    for ch in CHANNELS:
        sensor = ch.partition("_")[0]
        if kind == "increments":
            units[ch], to_si[ch] = ("rad" if sensor == "gyro" else "m/s"), 1.0
        elif kind == "counts":
            if mapping is not None and mapping.weights:
                w = channel_unit(mapping.weights, ch)
                key = f"weights.{ch}"
            else:  # a recording of counts that says its weights (navigate --record)
                w = channel_unit((meta or {})["weights"], ch)
                key = f"{mp}: weights.{ch}"
                if not isinstance(w, str):
                    raise LogError(
                        f"{mp}: weights: no weight for {ch} (give one by sensor, "
                        '"gyro"/"accel", or by channel, e.g. "0.1 arcsec", "125 ug*s")'
                    )
            assert w is not None
            units[ch] = f"{w}/count"
            to_si[ch] = parse_weight(w, sensor, key=key)
        else:
            u = mapping.units and channel_unit(mapping.units, ch) if mapping else None
            if not u:
                u = channel_unit(meta_units, ch)
                if u is not None:
                    if u == "pulse":
                        raise LogError(
                            f"{mp}: units.{ch} is 'pulse': a log of counts is read through a "
                            "mapping with [weights] (the weight of one count)"
                        )
                    try:
                        check_sensor_unit(sensor, u)
                    except ValueError as exc:
                        raise LogError(f"{mp}: units.{ch}: {exc}") from None
            u = u or DEFAULT_RATE_UNITS[sensor]
            units[ch], to_si[ch] = u, SENSOR_UNITS[u]
    return units, to_si


#: Columns that make a header look like a calibration log's (whose runs are then listed).
_CALIBRATION_COLUMNS = (CHAMBER, "table_outer_deg", "table_inner_deg")


@dataclass(frozen=True)
class NavHeader:
    """What a log's header and metadata say before it is opened (:func:`nav_log_header`).

    Attributes
    ----------
    path : Path
    columns : list of str
        The file's column names (as written).
    meta : dict, optional
        The sidecar metadata, unparsed.
    runs : list of str, optional
        The names in the run column, read only when the header looks like a calibration
        log's (a ``chamber_temp`` or two-axis turntable column, or a metadata ``protocol``);
        None otherwise or without a run column (a ``temp_out`` column without the encoder's
        or a reference's looks like one too).
    """

    path: Path
    columns: list[str]
    meta: dict[str, Any] | None
    runs: list[str] | None


def _existing_log(path: str | os.PathLike[str], fmt: str | None) -> tuple[Path, Format]:
    """The log's path and format, refusing a missing file or a folder (naming it)."""
    p = Path(path)
    f = format_of(p, fmt)
    if not p.exists():
        raise LogError(f"{p}: no such file")
    if p.is_dir():
        raise LogError(f"{p}: is a folder, not a log file")
    return p, f


def nav_log_header(
    path: str | os.PathLike[str], mapping: ColumnMapping | None = None, *, fmt: str | None = None
) -> NavHeader:
    """Read a log's header and metadata (and its runs, if it looks like a calibration log).

    Raises
    ------
    LogError
        As :func:`open_nav_log` for a missing file, an unknown format or an unreadable header.
    """
    p, f = _existing_log(path, fmt)
    cols, sep, _ = _header(p, f, mapping)
    meta = read_meta(p)
    run_col = RUN
    if mapping is not None:
        run_col = next((k for k, v in mapping.rename().items() if v == RUN), RUN)
    looks = (
        any(c in cols for c in _CALIBRATION_COLUMNS)
        or "protocol" in (meta or {})
        or (TEMP_OUT in cols and TABLE not in cols and not any(c in cols for c in REF_TRACK))
    )
    runs = None
    if looks and run_col in cols:
        try:
            if f == "parquet":
                # deferred on purpose: pyarrow is heavy and only Parquet needs it
                import pyarrow.parquet as pq

                col = pq.read_table(p, columns=[run_col]).column(0).to_pandas()
            else:
                col = pd.read_csv(p, sep=sep, usecols=[run_col], dtype=str).iloc[:, 0]
            runs = [str(r) for r in pd.unique(col.dropna())]
        except Exception:  # the runs only name the log; reading it proper says what is wrong
            runs = None
    return NavHeader(p, cols, meta, runs)


def open_nav_log(
    path: str | os.PathLike[str],
    mapping: ColumnMapping | None = None,
    run: str | None = None,
    *,
    fmt: str | None = None,
) -> NavLog:
    """Open a recorded-navigation log: its header and metadata, not its data.

    Parameters
    ----------
    path : path-like
        ``.csv``, ``.tsv`` or ``.parquet``.
    mapping : ColumnMapping, optional
        How to read a foreign log; None for canonical column names.
    run : str, optional
        Which run to read (overrides ``mapping.select_run``); needed when the file's ``run``
        column holds several.
    fmt : {"csv", "tsv", "parquet"}, optional
        Format, overriding the suffix.

    Returns
    -------
    NavLog

    Raises
    ------
    LogError
        For a missing file, an unknown format, columns named in the mapping that the file
        lacks, both rates and increments, some but not all six sensor columns, partial
        temperatures or reference columns, bad metadata; each names the file (and the
        columns). A Parquet file whose run column holds several runs (by its statistics)
        and no run chosen is refused here, listing the runs.
    ConfigError
        For a mapping that does not fit the file (``[units]`` on increments).
    """
    p, f = _existing_log(path, fmt)
    cols, sep, n_rows = _header(p, f, mapping)
    names = _resolve(p, cols, mapping)
    if TIME not in names:
        raise LogError(
            f"{p}: no time column {TIME!r} (columns found: {quoted_columns(cols)}); a foreign log "
            "names its time column in the mapping (time = ..., time_unit = ...)"
        )
    meta = read_meta(p)
    mp = f"{p}.meta.json"
    meta_weights = (meta or {}).get("weights")
    if meta_weights is not None and not isinstance(meta_weights, Mapping):
        raise LogError(f'{mp}: weights must be an object, e.g. {{"gyro": "0.1 arcsec"}}')
    kind, sensors = _kind(p, names, mapping, cols, meta_weights=bool(meta_weights))
    fields = _read_meta_fields(meta, mp)
    units, to_si = _units(kind, mapping, meta, mp)

    temp_cols: tuple[str, ...] = ()
    per_channel = [c for c in TEMP_CHANNELS if c in names]
    if len(per_channel) == 6 or (TEMP_IN in names):
        temp_cols = tuple(c if c in names else TEMP_IN for c in TEMP_CHANNELS)
    elif per_channel:
        lacking = [c for c in TEMP_CHANNELS if c not in names]
        raise LogError(
            f"{p}: inner temperature column(s) {', '.join(map(repr, lacking))} missing; give "
            f"one per channel or a shared {TEMP_IN!r}"
        )
    ref = [c for c in REF_TRACK if c in names]
    if ref and len(ref) < 3:
        lacking = [c for c in REF_TRACK if c not in names]
        raise LogError(
            f"{p}: reference column(s) {', '.join(map(repr, ref))} without "
            f"{', '.join(map(repr, lacking))}: a reference track needs all three"
        )
    chosen = run if run is not None else (mapping.select_run if mapping is not None else None)
    log = NavLog(
        path=p,
        mapping=mapping,
        meta=meta,
        kind=kind,
        units=units,
        to_si=to_si,
        names={c: names[c] for c in names},
        run=chosen,
        n_rows=n_rows,
        has_table=TABLE in names,
        has_temps=bool(temp_cols),
        has_temp_out=TEMP_OUT in names,
        has_ref=bool(ref),
        has_ref_heading=REF_HEADING in names,
        _fmt=f,
        _sep=sep,
        _sensors=sensors,
        _temp_cols=temp_cols,
        **fields,
    )
    if f == "parquet" and chosen is None and RUN in names and _parquet_several_runs(p, names[RUN]):
        raise log._several_runs()
    return log


def _parquet_several_runs(p: Path, col: str) -> bool:
    """Whether a Parquet file's run column holds several names, by its statistics."""
    # deferred on purpose: pyarrow is heavy and only Parquet needs it
    import pyarrow.parquet as pq

    md = pq.ParquetFile(p).metadata
    try:
        j = md.schema.to_arrow_schema().get_field_index(col)
        if j < 0:
            return False
        values: set[object] = set()
        for g in range(md.num_row_groups):
            st = md.row_group(g).column(j).statistics
            if st is None or not st.has_min_max:
                return False  # unknown here: the pieces will tell
            values.update((st.min, st.max))
            if len(values) > 1:
                return True
    except Exception:  # statistics are a shortcut only
        return False
    return False
