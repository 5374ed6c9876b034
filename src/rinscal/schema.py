"""The canonical calibration log: its columns and its validation.

A calibration log is one table, one row per sample, several runs stacked:

=================  ==========================================================================
column             meaning
=================  ==========================================================================
``time_s``         seconds since this run's power-on; strictly increasing within a run [s]
``run``            name of one continuous recording, e.g. ``soak_+07C`` (text)
``gyro_x`` ...     the six sensor channels of :data:`CHANNELS`, raw output in any consistent
                   unit (pulses, deg/h, µg, ...); NaN marks a dropped sample and is kept
``temp_<channel>`` inner temperature of that sensor [°C]; or one shared ``temp_in`` [°C]
``temp_out``       outer (package surface) temperature [°C], optional
``chamber_temp``   chamber set point or reading [°C], optional
=================  ==========================================================================

Other columns are kept untouched. Rows are never dropped or reordered.

Row numbers in error messages are *data row* numbers: 1-based, the header not counted, so
data row 1 is the first sample (line 2 of a CSV/TSV file with a header line).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from rinscal.errors import ConfigError, LogError
from rinscal.units import SENSOR_UNITS, check_sensor_unit

#: The six sensor channels, in the order used everywhere (arrays of shape (n, 6)).
CHANNELS: tuple[str, ...] = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
#: The gyroscope channels (first three of :data:`CHANNELS`).
GYRO_CHANNELS: tuple[str, ...] = CHANNELS[:3]
#: The accelerometer channels (last three of :data:`CHANNELS`).
ACCEL_CHANNELS: tuple[str, ...] = CHANNELS[3:]


def sensor_type(channel: str) -> str:
    """``"gyro"`` or ``"accel"``: the sensor type of a channel of :data:`CHANNELS`."""
    return "gyro" if channel in GYRO_CHANNELS else "accel"


#: Time since this run's power-on [s].
TIME = "time_s"
#: Run name (text).
RUN = "run"
#: Shared inner temperature [°C], used when there is no per-channel column.
TEMP_IN = "temp_in"
#: Outer (package surface) temperature [°C], optional.
TEMP_OUT = "temp_out"
#: Chamber temperature [°C], optional.
CHAMBER = "chamber_temp"


def temp_column(channel: str) -> str:
    """Name of the per-channel inner temperature column of ``channel``.

    Parameters
    ----------
    channel : str
        One of :data:`CHANNELS`.

    Returns
    -------
    str
        ``"temp_<channel>"``, e.g. ``"temp_accel_x"``.
    """
    if channel not in CHANNELS:
        raise ValueError(f"unknown channel {channel!r}; channels are {', '.join(CHANNELS)}")
    return f"temp_{channel}"


#: Per-channel inner temperature columns, in :data:`CHANNELS` order.
TEMP_CHANNELS: tuple[str, ...] = tuple(f"temp_{c}" for c in CHANNELS)
#: Columns every log must have.
REQUIRED: tuple[str, ...] = (TIME, RUN, *CHANNELS)
#: Every column name with a meaning in the canonical schema.
CANONICAL: tuple[str, ...] = (*REQUIRED, *TEMP_CHANNELS, TEMP_IN, TEMP_OUT, CHAMBER)

_ROWS = "data row numbers are 1-based, header not counted"
_NAN_LIKE = frozenset({"nan", "+nan", "-nan"})


def temperature_column(df: pd.DataFrame, channel: str) -> str:
    """Column holding the inner temperature of ``channel`` in a log.

    Parameters
    ----------
    df : DataFrame
        A calibration log (validated or not).
    channel : str
        One of :data:`CHANNELS`.

    Returns
    -------
    str
        ``"temp_<channel>"`` if the log has it, else ``"temp_in"``.

    Raises
    ------
    LogError
        If the log has neither column.
    """
    col = temp_column(channel)
    if col in df.columns:
        return col
    if TEMP_IN in df.columns:
        return TEMP_IN
    raise LogError(f"no inner temperature for {channel}: neither column {col!r} nor {TEMP_IN!r}")


def temperature_columns(df: pd.DataFrame) -> list[str]:
    """Every temperature column present in ``df``, in schema order.

    Parameters
    ----------
    df : DataFrame
        A calibration log.

    Returns
    -------
    list of str
        The present ones among ``temp_<channel>``, ``temp_in``, ``temp_out``,
        ``chamber_temp``.
    """
    return [c for c in (*TEMP_CHANNELS, TEMP_IN, TEMP_OUT, CHAMBER) if c in df.columns]


def col_label(column: str, names: Mapping[str, str] | None) -> str:
    """Column name for a message, with its name in the file when it was renamed."""
    original = (names or {}).get(column)
    if original and original != column:
        return f"column {column!r} (from {original!r})"
    return f"column {column!r}"


def _fmt(value: object) -> str:
    text = repr(value) if isinstance(value, str) else str(value)
    return text if len(text) <= 40 else text[:37] + "..."


def as_float(
    values: pd.Series,
    source: str,
    column: str,
    names: Mapping[str, str] | None = None,
    *,
    copy: bool = True,
    first_row: int = 0,
) -> np.ndarray:
    """Convert one column to float64, refusing any value that is not a number.

    Empty cells and NaN stay NaN (callers decide whether NaN is allowed).

    Parameters
    ----------
    values : Series
        The column as read.
    source : str
        File (or other origin) named in the error message.
    column : str
        Column name named in the error message.
    names : mapping, optional
        Canonical name -> name in the file, for columns renamed by a mapping.
    copy : bool
        If false, a float64 column is returned without copying (read-only use).
    first_row : int
        Rows of the file before ``values`` (a piece of a log read in pieces), for messages.

    Returns
    -------
    ndarray, shape (n,)
        The values as float64.

    Raises
    ------
    LogError
        Naming the file, the column, the first non-numeric value and its data row.
    """
    if pd.api.types.is_bool_dtype(values.dtype):
        raise LogError(f"{source}: {col_label(column, names)} holds true/false values, not numbers")
    if values.dtype == np.float64:
        return values.to_numpy(dtype=np.float64, copy=copy)
    if pd.api.types.is_numeric_dtype(values.dtype) and not pd.api.types.is_complex_dtype(
        values.dtype
    ):
        return values.to_numpy(dtype=np.float64, na_value=np.nan, copy=True)
    coerced = pd.to_numeric(values, errors="coerce")
    bad = coerced.isna().to_numpy() & values.notna().to_numpy()
    if bad.any():
        raw = values.to_numpy(dtype=object)
        for pos in np.flatnonzero(bad):
            val = raw[pos]
            if isinstance(val, str) and val.strip().lower() in _NAN_LIKE:
                continue
            raise LogError(
                f"{source}: {col_label(column, names)}, data row {first_row + pos + 1}: "
                f"non-numeric value {_fmt(val)} ({_ROWS})"
            )
    try:
        return coerced.to_numpy(dtype=np.float64, na_value=np.nan, copy=True)
    except (TypeError, ValueError) as exc:  # e.g. complex numbers
        raise LogError(f"{source}: {col_label(column, names)} is not real-valued: {exc}") from exc


def check_finite(
    x: np.ndarray,
    source: str,
    column: str,
    names: Mapping[str, str] | None,
    allow_nan: bool,
    why: str,
    first_row: int = 0,
) -> None:
    """Refuse a column (float) holding a non-finite value (``allow_nan``: an infinite one),
    naming the file, the column and the data row of the first.

    One pass over the values without a temporary where none is found (the common case): a
    sum that is finite has no NaN or infinity among its terms, and the largest and smallest
    of the values other than NaN are finite when none is infinite. Only when that fails
    (or the sum overflows) are the values looked at one by one.
    """
    x = np.asarray(x)
    if x.size == 0:
        return
    if allow_nan:
        if -np.inf < np.fmin.reduce(x, axis=None) and np.fmax.reduce(x, axis=None) < np.inf:
            return
        if np.isnan(x).all():  # fmin/fmax of NaN alone: NaN
            return
    else:
        with np.errstate(over="ignore", invalid="ignore"):  # inf - inf, or a sum that overflows
            total = np.add.reduce(x, axis=None)
        if np.isfinite(total):
            return
    bad = np.isinf(x) if allow_nan else ~np.isfinite(x)
    if bad.any():
        pos = int(np.argmax(bad))
        what = "missing value (NaN or empty cell)" if np.isnan(x[pos]) else f"value {x[pos]}"
        raise LogError(
            f"{source}: {col_label(column, names)}, data row {first_row + pos + 1}: {what}; {why} "
            f"({_ROWS})"
        )


def _run_codes(run: pd.Series) -> tuple[np.ndarray, np.ndarray]:
    codes, uniques = pd.factorize(run, sort=False)
    return codes.astype(np.int64, copy=False), np.asarray(uniques, dtype=object)


def quoted_columns(cols: Sequence[str], most: int = 20) -> str:
    """Column names for a message: quoted (padding shows), the first ``most``, then "..."."""
    return ", ".join(map(repr, cols[:most])) + (", ..." if len(cols) > most else "")


def validate_log(
    df: pd.DataFrame,
    source: str = "<log>",
    *,
    names: Mapping[str, str] | None = None,
    first_row: int = 0,
) -> pd.DataFrame:
    """Check a calibration log against the canonical schema and normalise its types.

    Parameters
    ----------
    df : DataFrame
        The log, canonical column names.
    source : str
        Name of the file (or other origin) used in error messages.
    names : mapping, optional
        Canonical column name -> name in the original file, for logs read through a
        column mapping; only used to make error messages point at the file's columns.
    first_row : int
        Data rows of the file before ``df`` (a log read run by run), so that messages give
        the row's number in the file.

    Returns
    -------
    DataFrame
        A new frame, same rows in the same order and same index: ``run`` as text, every
        sensor and temperature column and ``time_s`` as float64, other columns untouched.

    Raises
    ------
    LogError
        Naming ``source``, the column and the first offending data row (1-based, header not
        counted) for: a table with fewer than two columns (not a table), no rows, a missing
        required column, a non-numeric value, NaN or inf in ``time_s`` or a temperature, inf
        in a sensor channel, an empty run name, time not strictly increasing within a run,
        a run with fewer than two samples. NaN in a sensor channel (a dropped sample) is
        allowed and kept.
    """
    if not isinstance(df, pd.DataFrame):
        raise LogError(f"{source}: not a table (got {type(df).__name__})")
    cols = [str(c) for c in df.columns]
    if len(cols) < 2:
        found = f"one column {cols[0]!r}" if cols else "no columns"
        raise LogError(
            f"{source}: not a table: {found}; a calibration log has columns "
            f"{', '.join(REQUIRED)} and temperatures (wrong separator, or not a log at all?)"
        )
    if len(set(cols)) != len(cols):
        dup = sorted({c for c in cols if cols.count(c) > 1})
        raise LogError(f"{source}: duplicate column(s) {', '.join(map(repr, dup))}")
    missing = [c for c in REQUIRED if c not in cols]
    if missing:
        padded = [c for c in cols if c != c.strip() and c.strip() in CANONICAL]
        hint = (
            f"; column name(s) {', '.join(map(repr, padded))} have spaces around them: "
            "remove the spaces in the header, or map them (the mapping's columns, col=)"
            if padded
            else "; a foreign log needs a column mapping"
        )
        raise LogError(
            f"{source}: missing required column(s) {', '.join(map(repr, missing))} "
            f"(columns found: {quoted_columns(cols)}){hint}"
        )
    per_channel = [c for c in TEMP_CHANNELS if c in cols]
    if len(per_channel) < len(TEMP_CHANNELS) and TEMP_IN not in cols:
        absent = [c for c in TEMP_CHANNELS if c not in cols]
        raise LogError(
            f"{source}: missing inner temperature column(s) {', '.join(map(repr, absent))}; "
            f"give one per channel or a shared {TEMP_IN!r}"
        )
    if len(df) == 0:
        raise LogError(f"{source}: no data rows (only a header)")

    # A shallow copy: columns already float64 are shared, not copied (pandas copy-on-write
    # keeps the caller's frame unchanged), so validating a 7.5 M-row log costs no memory.
    out = df.copy(deep=False)
    out.columns = cols
    run = out[RUN]
    empty = run.isna().to_numpy() | (run == "").to_numpy(dtype=bool, na_value=False)
    if empty.any():
        pos = int(np.argmax(empty))
        raise LogError(
            f"{source}: {col_label(RUN, names)}, data row {first_row + pos + 1}: empty run name "
            f"({_ROWS})"
        )
    coded = None
    if isinstance(run.dtype, pd.CategoricalDtype):  # Parquet's dictionary: names taken once
        names_ = pd.array(run.cat.categories.astype(str))
        cat = run.cat.codes.to_numpy()
        out[RUN] = pd.Series(names_.take(cat), index=run.index)
        coded = _category_codes(cat, names_)  # the runs from the codes: no text hashed
    elif not pd.api.types.is_string_dtype(run.dtype) or run.dtype == object:
        out[RUN] = run.astype(str)

    for col in CHANNELS:
        x = as_float(out[col], source, col, names, copy=False, first_row=first_row)
        why = "use an empty cell/NaN for a dropped sample"
        check_finite(x, source, col, names, allow_nan=True, why=why, first_row=first_row)
        if out[col].dtype != np.float64:
            out[col] = x
    for col in (TIME, *temperature_columns(out)):
        x = as_float(out[col], source, col, names, copy=False, first_row=first_row)
        why = "time must be finite" if col == TIME else "temperatures must be finite"
        check_finite(x, source, col, names, allow_nan=False, why=why, first_row=first_row)
        if out[col].dtype != np.float64:
            out[col] = x

    _check_runs(out[TIME].to_numpy(), out[RUN], source, names, first_row, coded)
    return out


def _category_codes(cat: np.ndarray, names: Any) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_run_codes` of a categorical run column from its codes ``cat`` (none missing)
    and its categories as text ``names``: categories alike as text are one run, those no
    row uses are left out (a Parquet dictionary may hold other runs' names)."""
    same, uniques = pd.factorize(names, sort=False)
    codes = same[cat]
    present = np.bincount(codes, minlength=len(uniques)) > 0
    number = np.cumsum(present) - 1  # the runs present, numbered from 0
    return number[codes].astype(np.int64, copy=False), np.asarray(uniques, dtype=object)[present]


def _check_runs(
    t: np.ndarray,
    run: pd.Series,
    source: str,
    names: Mapping[str, str] | None,
    first_row: int = 0,
    coded: tuple[np.ndarray, np.ndarray] | None = None,
) -> None:
    """At least two samples per run, time strictly increasing within each run (``coded``:
    :func:`_run_codes` of ``run``, when found already)."""
    codes, uniques = _run_codes(run) if coded is None else coded
    counts = np.bincount(codes, minlength=len(uniques))
    short = np.flatnonzero(counts < 2)
    if short.size:
        _, first = np.unique(codes, return_index=True)  # first row of each run, by code
        k = int(short[np.argmin(first[short])])
        raise LogError(
            f"{source}: {col_label(RUN, names)}, data row {first_row + first[k] + 1}: run "
            f"{uniques[k]!r} has {counts[k]} sample(s); a run needs at least 2 ({_ROWS})"
        )
    n = len(t)
    change = np.flatnonzero(codes[1:] != codes[:-1]) + 1
    if change.size + 1 == len(uniques):  # every run is one contiguous block: plain diffs
        order = None
        same = np.ones(n - 1, dtype=bool)
        same[change - 1] = False
        tt = t
    else:  # interleaved runs: compare each sample with the previous one of its run
        order = np.argsort(codes, kind="stable")
        cs = codes[order]
        same = cs[1:] == cs[:-1]
        tt = t[order]
    bad = same & (tt[1:] <= tt[:-1])
    if bad.any():
        if order is None:
            rows = np.flatnonzero(bad) + 1
            prev = rows - 1
        else:
            idx = np.flatnonzero(bad)
            rows, prev = order[idx + 1], order[idx]
        j = int(np.argmin(rows))
        r, p = int(rows[j]), int(prev[j])
        raise LogError(
            f"{source}: {col_label(TIME, names)}, data row {first_row + r + 1}: time not strictly "
            f"increasing within run {run.iloc[r]!r} ({float(t[r]):.10g} s after "
            f"{float(t[p]):.10g} s at data row {first_row + p + 1}) ({_ROWS})"
        )


# --------------------------------------------------------------------------- navigation log
#: The recorded-navigation log (``rinscal navigate --log``): one row per IMU sample of one
#: recording, read through the same mapping mechanism as a calibration log.
#:
#: ======================  ===================================================================
#: column                  meaning
#: ======================  ===================================================================
#: ``time_s``              time of the *end* of each sample's interval [s], strictly increasing
#: ``run``                 optional; a file with several runs needs ``--run``
#: ``gyro_*``/``accel_*``  rates in the IMU's own (rotating) frame r, right-forward-up, in the
#:                         declared units (default deg/h and µg; rad/s, deg/s, m/s², mg, g)
#: ``dtheta_*``            *or* angle increments over the interval ending at ``time_s`` [rad]
#: ``dvel_*``              with velocity increments [m/s] (PSINS, KF-GINS, navigation IMUs)
#: ``table_deg``           optional encoder angle of the IMU frame about the body's z [deg];
#:                         absent: the IMU is fixed to the body
#: ``temp_*``              temperatures as in the calibration log (needed with a model)
#: ``ref_lat_deg`` ...     optional reference track ``ref_lat_deg, ref_lon_deg, ref_h_m``
#: ======================  ===================================================================
NAV_RATES: tuple[str, ...] = CHANNELS
#: Angle increments over each sample's interval, r frame [rad].
DTHETA: tuple[str, ...] = ("dtheta_x", "dtheta_y", "dtheta_z")
#: Velocity increments over each sample's interval, r frame [m/s].
DVEL: tuple[str, ...] = ("dvel_x", "dvel_y", "dvel_z")
#: Encoder angle of the IMU frame relative to the body, about z [deg].
TABLE = "table_deg"
#: Reference track columns: geodetic latitude, longitude [deg], ellipsoidal height [m].
REF_TRACK: tuple[str, ...] = ("ref_lat_deg", "ref_lon_deg", "ref_h_m")
#: Optional reference heading of the body, clockwise from true north [deg].
REF_HEADING = "ref_heading_deg"
#: Optional reference velocity of a track file: east, north, up [m/s] (all three or none;
#: a FOG-INS or GNSS receiver's velocity, used by the filter as a measurement).
REF_VELOCITY: tuple[str, ...] = ("ref_ve_mps", "ref_vn_mps", "ref_vu_mps")
#: An interval longer than this many nominal intervals is a gap in a recording.
GAP_FACTOR = 1.5
#: Every column with a meaning in the recorded-navigation log.
NAV_CANONICAL: tuple[str, ...] = (
    TIME,
    RUN,
    *NAV_RATES,
    *DTHETA,
    *DVEL,
    TABLE,
    *TEMP_CHANNELS,
    TEMP_IN,
    TEMP_OUT,
    CHAMBER,
    *REF_TRACK,
    REF_HEADING,
)


@dataclass(frozen=True)
class NavSamples:
    """A piece of a recorded-navigation log, in SI and in the IMU frame r (right-forward-up).

    Pieces come in time order; together they are the recording, each sample once.

    Attributes
    ----------
    t : ndarray, shape (n,) [s]
        End of each sample's interval, strictly increasing (``time_s``).
    dt : ndarray, shape (n,) [s]
        Length of each sample's interval (``t[k] − t[k−1]``; the recording's first sample:
        the nominal interval).
    dtheta : ndarray, shape (n, 3) [rad]
        Angle increments over each interval, r frame.
    dv : ndarray, shape (n, 3) [m/s]
        Velocity increments over each interval, r frame.
    first_row : int
        Data row of the file holding ``t[0]`` (1-based, header not counted).
    table : ndarray, shape (n,) [rad], optional
        Encoder angle of r about the body's z (sign and zero of the mapping applied, not
        unwrapped); None: the IMU is fixed to the body.
    temps : ndarray, shape (n, 6) [°C], optional
        Inner temperature per sensor channel in :data:`CHANNELS` order (a shared
        ``temp_in`` repeated).
    temp_out : ndarray, shape (n,) [°C], optional
        Outer (package) temperature.
    ref : ndarray, shape (n, 3), optional
        Reference ``lat [rad], lon [rad], h [m]`` from the log's own columns.
    ref_heading : ndarray, shape (n,) [rad], optional
        Reference heading of the body, clockwise from north.
    """

    t: np.ndarray
    dt: np.ndarray
    dtheta: np.ndarray
    dv: np.ndarray
    first_row: int = 1
    table: np.ndarray | None = None
    temps: np.ndarray | None = None
    temp_out: np.ndarray | None = None
    ref: np.ndarray | None = None
    ref_heading: np.ndarray | None = None

    @property
    def n(self) -> int:
        """Samples in the piece."""
        return int(self.t.shape[0])


def unit_factors(
    meta: Mapping[str, Any] | None, channels: Sequence[str] = CHANNELS
) -> tuple[dict[str, str | None], dict[str, float | None]]:
    """Units of the channels and their SI value, from a log's metadata.

    ``meta["unit_to_si"][channel]`` wins; else ``meta["units"][channel]`` through
    :data:`rinscal.units.SENSOR_UNITS`, or ``meta["pulse_scale"][channel]`` for ``"pulse"``.

    Returns
    -------
    units : dict of str to str or None
    unit_to_si : dict of str to float or None [SI per log unit]

    Raises
    ------
    ConfigError
        A unit that is not one of the channel's sensor type (:mod:`rinscal.units`), or
        whose ``unit_to_si`` contradicts it.
    """
    meta = meta or {}
    units_m = meta.get("units") or {}
    to_si = meta.get("unit_to_si") or {}
    pulse = meta.get("pulse_scale") or {}
    units: dict[str, str | None] = {}
    factors: dict[str, float | None] = {}
    for c in channels:
        u = units_m.get(c, units_m.get(sensor_type(c)))
        units[c] = str(u) if u is not None else None
        k = to_si.get(c)
        if k is None and u is not None:
            k = pulse.get(c) if u == "pulse" else SENSOR_UNITS.get(str(u))
        ok = isinstance(k, (int, float)) and not isinstance(k, bool) and math.isfinite(k) and k > 0
        factors[c] = float(k) if ok else None
        if u is not None:
            try:
                check_sensor_unit(sensor_type(c), str(u), factors[c])
            except ValueError as exc:
                raise ConfigError(f"the log's units: {c}: {exc}") from None
    return units, factors
