"""Read a recorded-navigation log (``rinscal navigate --log``) as SI pieces in the IMU frame.

A recording (CSV, TSV or Parquet, one row per IMU sample, see the "navigation log" section
of :mod:`rinscal.schema`) is read in pieces of about :data:`rinscal.io.PIECE_ROWS` rows,
never whole: only the columns it needs (Parquet record batches, CSV/TSV chunks), each piece
turned into a :class:`rinscal.schema.NavSamples` of angle and velocity increments [rad, m/s]
in the IMU frame r (right-forward-up), time in seconds.

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

A foreign file is read through a :class:`NavMapping`, from a small TOML file
(:func:`read_nav_mapping`) or built in code, never by editing the file::

    # frd_counts.toml: a front-right-down IMU logging integer counts, a µs timestamp
    separator = "comma"         # "tab", "comma", "semicolon" or "auto" (default: by suffix)
    time = "t_us"               # foreign time column -> time_s ...
    time_unit = "us"            # ... in s, ms or us
    temperature = "imu_temp"    # one shared inner temperature -> temp_in
    axes = ["y", "x", "-z"]     # our x, y, z from the file's (renamed) axes, with sign
    table_sign = -1             # encoder: angle = sign * raw - zero
    table_zero_deg = 12.5       # [deg]
    table_unit = "deg"          # unit of the raw encoder column: deg or rad
    run = "sea_trial_2"         # which run to read when the file has several

    [columns]                   # foreign name -> canonical name (rinscal.schema.NAV_CANONICAL)
    cnt_gx = "gyro_x"           # counts may be mapped onto gyro_*/accel_* or dtheta_*/dvel_*
    cnt_gy = "gyro_y"
    cnt_gz = "gyro_z"
    cnt_ax = "accel_x"
    cnt_ay = "accel_y"
    cnt_az = "accel_z"
    encoder = "table_deg"

    [weights]                   # counts: SI per count, by sensor ("gyro", "accel") or channel
    gyro = "0.1 arcsec"         # angle units: rad, deg, arcsec
    accel = "125 ug*s"          # velocity units: m/s, mm/s, ug*s, mg*s, g*s (g = 9.80665 m/s²)

    # [units]                   # rates instead of counts: the units of the rate columns
    # gyro = "rad/s"            # (rinscal.units.SENSOR_UNITS names), by sensor or channel
    # accel = "m/s^2"

``units`` and ``weights`` are keyed by the file's channels *before* ``axes`` (the scale of
a sensor column belongs to that column); ``axes`` then permutes and flips gyros,
accelerometers and the per-channel temperatures alike (front-right-down to right-forward-up
is ``["y", "x", "-z"]``). A file whose columns already have the canonical names needs no
mapping; columns that are neither canonical nor mapped are never read.

Sidecar metadata ``<log>.meta.json`` (:func:`rinscal.io.read_meta`) may give ``rate_hz``,
``units`` (of rate columns), ``site`` = ``{"lat_deg", "lon_deg", "h_m"}``, ``heading_deg``,
``noise`` = ``{"gyro_noise_density" [rad/√s], "accel_noise_density" [m/s²/√Hz]}`` (and
optionally ``"gyro_bias_rw"`` [rad/s/√s], ``"accel_bias_rw"`` [m/s²/√s]) and
``utc_start`` (ISO 8601, the UTC of ``time_s`` = 0, for NMEA reference tracks).

A reference track may also be a separate file, read by :func:`read_track`: a table with
``time_s, ref_lat_deg, ref_lon_deg, ref_h_m`` or NMEA GGA sentences.

Row numbers in messages are data rows of the file: 1-based, the header not counted.
"""

from __future__ import annotations

import csv
import math
import os
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

from rinscal.errors import ConfigError, LogError
from rinscal.io import (
    _CSV_READ_KW,
    _NA_STRINGS,
    PIECE_ROWS,
    SEPARATORS,
    TIME_UNITS,
    _check_parquet,
    _sniff_text,
    _text_frames,
    channel_unit,
    check_mapping_basics,
    format_of,
    mapping_keys,
    mapping_toml,
    read_meta,
)
from rinscal.schema import (
    CHANNELS,
    DTHETA,
    DVEL,
    GAP_FACTOR,
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
    NavSamples,
    _check_finite,
    _label,
    as_float,
)
from rinscal.units import ARCSEC_TO_RAD, DEG_TO_RAD, G0, SENSOR_UNITS, check_sensor_unit

__all__ = [
    "ANGLE_WEIGHT_UNITS",
    "VELOCITY_WEIGHT_UNITS",
    "Gap",
    "NavLog",
    "NavMapping",
    "Track",
    "open_nav_log",
    "parse_utc",
    "parse_weight",
    "read_nav_mapping",
    "read_track",
]

Kind = Literal["rates", "increments", "counts"]

#: Units of a gyro pulse weight and their value [rad].
ANGLE_WEIGHT_UNITS: dict[str, float] = {"rad": 1.0, "deg": DEG_TO_RAD, "arcsec": ARCSEC_TO_RAD}
#: Units of an accelerometer pulse weight and their value [m/s].
VELOCITY_WEIGHT_UNITS: dict[str, float] = {
    "m/s": 1.0,
    "mm/s": 1e-3,
    "ug*s": 1e-6 * G0,
    "µg*s": 1e-6 * G0,
    "mg*s": 1e-3 * G0,
    "g*s": G0,
}
#: Default units of rate columns when neither the mapping nor the metadata says.
DEFAULT_RATE_UNITS: dict[str, str] = {"gyro": "deg/h", "accel": "ug"}
#: Samples whose median interval is the nominal one when the metadata has no ``rate_hz``.
NOMINAL_SAMPLES = 1001
#: An interval longer than this many nominal intervals is a gap.

_ROWS = "data row numbers are 1-based, header not counted"
_GROUPS = {"gyro": CHANNELS[:3], "accel": CHANNELS[3:]}
_AXES = ("x", "y", "z")
_IDENTITY = ((0, 1.0), (1, 1.0), (2, 1.0))
_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_WEIGHT_RE = re.compile(rf"^\s*({_NUMBER})?\s*\*?\s*([^\s\d].*?)\s*$")


# --------------------------------------------------------------------------- mapping


def parse_weight(text: str, sensor: str, key: str = "weights") -> float:
    """SI value of one count from a pulse weight such as ``"0.1 arcsec"`` or ``"125 ug*s"``.

    Parameters
    ----------
    text : str
        A positive number and a unit (the number may be left out: one unit).
    sensor : {"gyro", "accel"}
        Gyro weights are angles (:data:`ANGLE_WEIGHT_UNITS`), accelerometer weights
        velocities (:data:`VELOCITY_WEIGHT_UNITS`).
    key : str
        Named in the error message.

    Returns
    -------
    float
        rad per count (gyro) or m/s per count (accel).

    Raises
    ------
    ConfigError
        For an unknown unit, a unit of the other sensor type or a weight that is not positive.
    """
    table = ANGLE_WEIGHT_UNITS if sensor == "gyro" else VELOCITY_WEIGHT_UNITS
    m = _WEIGHT_RE.match(text) if isinstance(text, str) else None
    unit = m.group(2).replace(" ", "") if m else None
    if m is None or unit not in table:
        what = "angle" if sensor == "gyro" else "velocity"
        raise ConfigError(
            f"{key}: {text!r} is not a {sensor} pulse weight: give a number and an {what} unit, "
            f"e.g. {'0.1 arcsec' if sensor == 'gyro' else '125 ug*s'} (units: "
            f"{', '.join(table)})"
        )
    value = float(m.group(1)) if m.group(1) is not None else 1.0
    if not math.isfinite(value) or value <= 0.0:
        raise ConfigError(
            f"{key}: {text!r}: a pulse weight must be positive (flip an axis with axes, "
            'e.g. ["x", "-y", "z"])'
        )
    return value * table[unit]


def _parse_axes(axes: Any) -> tuple[tuple[int, float], ...]:
    """(file axis index, sign) for our x, y, z; ConfigError unless a signed permutation."""
    bad = ConfigError(
        f"axes: {axes!r} is not a permutation of x, y, z, each with an optional sign "
        '(front-right-down to right-forward-up is ["y", "x", "-z"])'
    )
    if isinstance(axes, str) or not isinstance(axes, list | tuple) or len(axes) != 3:
        raise bad
    out = []
    for a in axes:
        if not isinstance(a, str):
            raise bad
        s = a.strip().lower()
        sign = -1.0 if s.startswith("-") else 1.0
        s = s.lstrip("+-")
        if s not in _AXES:
            raise bad
        out.append((_AXES.index(s), sign))
    if sorted(i for i, _ in out) != [0, 1, 2]:
        raise bad
    m = np.zeros((3, 3))
    for row, (i, sign) in enumerate(out):
        m[row, i] = sign
    if np.linalg.det(m) < 0:  # a mirror: no rotation of a real IMU gives it
        raise ConfigError(
            f"axes: {axes!r} turns a right-handed frame into a left-handed one (a mirror); "
            "flip one axis more or one fewer (front-right-down to right-forward-up is "
            '["y", "x", "-z"])'
        )
    return tuple(out)


@dataclass(frozen=True)
class NavMapping:
    """How to read a foreign recorded-navigation log (keys as in the module docstring).

    Parameters
    ----------
    columns : mapping of str to str
        Foreign column -> canonical name of :data:`rinscal.schema.NAV_CANONICAL`.
    time : str, optional
        Foreign time column, renamed to ``time_s``.
    time_unit : {"s", "ms", "us"}
        Unit of the time column; converted to seconds (an integer column exactly).
    separator : {"auto", "tab", "comma", "semicolon"}, optional
        Field separator of a text file; None: by suffix (``.tsv`` tab, else comma).
    temperature : str, optional
        One foreign temperature column shared by all sensors, renamed to ``temp_in`` [°C].
    units : mapping of str to str
        Rate columns: ``"gyro"``/``"accel"`` or a channel of :data:`rinscal.schema.CHANNELS`
        (the file's, before ``axes``) -> a :data:`rinscal.units.SENSOR_UNITS` name.
    weights : mapping of str to str
        Count columns: ``"gyro"``/``"accel"`` or a channel -> the weight of one count, e.g.
        ``"0.1 arcsec"``, ``"125 ug*s"`` (:func:`parse_weight`); all six channels must have
        one. With weights the six sensor columns hold integer counts per interval.
    axes : tuple of 3 str
        Our x, y, z from the file's axes (after renaming), each with an optional sign.
    table_sign : {1.0, -1.0}
        Sign of the encoder column.
    table_zero_deg : float [deg]
        Encoder zero, subtracted after the sign: ``angle = sign · raw − zero``.
    table_unit : {"deg", "rad"}
        Unit of the raw encoder column (``table_zero_deg`` is always in degrees).
    run : str, optional
        Which run to read when the file has a ``run`` column with several runs.
    """

    columns: Mapping[str, str] = field(default_factory=dict)
    time: str | None = None
    time_unit: str = "s"
    separator: str | None = None
    temperature: str | None = None
    units: Mapping[str, str] = field(default_factory=dict)
    weights: Mapping[str, str] = field(default_factory=dict)
    axes: tuple[str, str, str] = ("x", "y", "z")
    table_sign: float = 1.0
    table_zero_deg: float = 0.0
    table_unit: str = "deg"
    run: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "columns", dict(self.columns))
        object.__setattr__(self, "units", dict(self.units))
        object.__setattr__(self, "weights", dict(self.weights))
        _parse_axes(self.axes)
        object.__setattr__(self, "axes", tuple(self.axes))
        for foreign, canon in self.columns.items():
            if not isinstance(foreign, str) or canon not in NAV_CANONICAL:
                raise ConfigError(
                    f"columns: {foreign!r} -> {canon!r}: {canon!r} is not a column of the "
                    f"navigation log (canonical: {', '.join(NAV_CANONICAL)})"
                )
        check_mapping_basics(self)
        for key, unit in self.units.items():
            if key not in CHANNELS and key not in _GROUPS:
                raise ConfigError(
                    f"units: {key!r} is not 'gyro', 'accel' or a channel ({', '.join(CHANNELS)})"
                )
            sensor = key.partition("_")[0]
            if unit == "pulse":
                raise ConfigError(
                    f"units.{key}: counts are given by their weight: [weights] {sensor} = "
                    f"{'0.1 arcsec' if sensor == 'gyro' else '125 ug*s'} (say), not a unit"
                )
            try:
                check_sensor_unit(sensor, unit)
            except (ValueError, TypeError) as exc:
                raise ConfigError(f"units.{key}: {exc}") from None
        for key, w in self.weights.items():
            if key not in CHANNELS and key not in _GROUPS:
                raise ConfigError(
                    f"weights: {key!r} is not 'gyro', 'accel' or a channel ({', '.join(CHANNELS)})"
                )
            parse_weight(w, key.partition("_")[0], key=f"weights.{key}")
        if self.weights:
            lacking = [c for c in CHANNELS if channel_unit(self.weights, c) is None]
            if lacking:
                raise ConfigError(
                    f"weights: no weight for {', '.join(lacking)}; counts need a weight for "
                    "all six channels (give 'gyro' and 'accel')"
                )
            if self.units:
                raise ConfigError(
                    "units and weights: give [units] for rate columns or [weights] for count "
                    "columns, not both"
                )
        if self.table_sign not in (1, -1) or isinstance(self.table_sign, bool):
            raise ConfigError(f"table_sign: {self.table_sign!r} is not 1 or -1")
        object.__setattr__(self, "table_sign", float(self.table_sign))
        zero = self.table_zero_deg
        if isinstance(zero, bool) or not isinstance(zero, int | float) or not math.isfinite(zero):
            raise ConfigError(f"table_zero_deg: {zero!r} is not a finite number [deg]")
        object.__setattr__(self, "table_zero_deg", float(zero))
        if self.table_unit not in ("deg", "rad"):
            raise ConfigError(f"table_unit: {self.table_unit!r} is not 'deg' or 'rad'")
        if self.run is not None and (not isinstance(self.run, str) or not self.run):
            raise ConfigError(f"run: {self.run!r} is not a run name")

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "<mapping>") -> NavMapping:
        """Build a mapping from parsed TOML (or any dict of the same keys).

        Raises
        ------
        ConfigError
            Naming ``source`` and the offending key.
        """
        kw = mapping_keys(cls, data, source, tables=("columns", "units", "weights"))
        for key in ("time", "time_unit", "separator", "temperature", "table_unit", "run"):
            if key in kw and not isinstance(kw[key], str):
                raise ConfigError(f"{source}: {key} must be a string, got {kw[key]!r}")
        try:
            return cls(**kw)
        except ConfigError as exc:
            raise ConfigError(f"{source}: {exc}") from None

    def foreign_columns(self) -> list[str]:
        """Every foreign column the mapping names (and so the file must have)."""
        return list(self.columns) + [c for c in (self.time, self.temperature) if c is not None]

    def rename(self) -> dict[str, str]:
        """Foreign column -> canonical name, time and temperature included."""
        out = dict(self.columns)
        if self.time is not None:
            out[self.time] = TIME
        if self.temperature is not None:
            out[self.temperature] = TEMP_IN
        return out


def read_nav_mapping(path: str | os.PathLike[str]) -> NavMapping:
    """Read a :class:`NavMapping` from a TOML file.

    Raises
    ------
    ConfigError
        If the file is missing, not TOML, or has an unknown or invalid key (named with the
        file).
    """
    p = Path(path)
    return NavMapping.from_dict(mapping_toml(p), source=str(p))


# --------------------------------------------------------------------------- the log


@dataclass(frozen=True)
class Gap:
    """An interval longer than :data:`GAP_FACTOR` nominal intervals.

    Attributes
    ----------
    time_s : float [s]
        ``time_s`` of the sample that ends the gap (the first one after it).
    row : int
        Its data row (1-based, header not counted).
    length_s : float [s]
        The interval ``t[k] − t[k−1]``.
    missing_samples : int
        About how many samples are missing: ``round(length_s / nominal) − 1``.
    """

    time_s: float
    row: int
    length_s: float
    missing_samples: int


@dataclass
class NavLog:
    """A recorded-navigation log opened by :func:`open_nav_log`: what its header and its
    metadata say, without reading the data; :meth:`pieces` reads the data.

    Attributes
    ----------
    path : Path
        The log file.
    mapping : NavMapping or None
        How it is read (None: canonical column names).
    meta : dict or None
        Its sidecar metadata ``<log>.meta.json``.
    kind : {"rates", "increments", "counts"}
        How the file gives the IMU's output.
    units : dict of str to str
        Per channel of :data:`rinscal.schema.CHANNELS` (the file's channel, before ``axes``):
        rates: the unit name (mapping, else ``meta["units"]``, else deg/h and µg);
        increments: ``"rad"``/``"m/s"``; counts: the weight, e.g. ``"0.1 arcsec/count"``.
    to_si : dict of str to float
        Per channel: rates: SI rate per unit [(rad/s)/unit, (m/s²)/unit]; increments: 1;
        counts: SI per count [rad, m/s].
    names : dict of str to str
        Canonical name -> the file's column, for every column read.
    run : str or None
        The run read (``run`` argument, else the mapping's); None: the file's only run.
    n_rows : int or None
        Data rows in the file (Parquet metadata; all runs); None for a text file.
    has_table, has_temps, has_temp_out, has_ref, has_ref_heading : bool
        Whether the pieces carry the encoder angle, the six inner temperatures, the outer
        temperature, the reference track columns, the reference heading.
    rate_hz : float or None [Hz]
        ``meta["rate_hz"]``: the nominal rate (else the median interval is used).
    site : tuple of float or None
        ``meta["site"]`` as ``(lat [rad], lon [rad], h [m])`` (``h_m`` 0 when not given).
    heading_deg : float or None [deg]
        ``meta["heading_deg"]``: the body's heading, clockwise from north.
    noise : dict of str to float or None
        ``meta["noise"]``: ``gyro_noise_density`` [rad/√s], ``accel_noise_density``
        [m/s²/√Hz].
    utc_start : datetime or None
        ``meta["utc_start"]``: the UTC of ``time_s`` = 0 (timezone-aware).
    gaps : list of Gap
        Filled while :meth:`pieces` runs (emptied when it starts again).
    """

    path: Path
    mapping: NavMapping | None
    meta: dict[str, Any] | None
    kind: Kind
    units: dict[str, str]
    to_si: dict[str, float]
    names: dict[str, str]
    run: str | None
    n_rows: int | None
    has_table: bool
    has_temps: bool
    has_temp_out: bool
    has_ref: bool
    has_ref_heading: bool
    rate_hz: float | None
    site: tuple[float, float, float] | None
    heading_deg: float | None
    noise: dict[str, float] | None
    utc_start: datetime | None
    gaps: list[Gap] = field(default_factory=list)
    _fmt: str = field(default="csv", repr=False)
    _sep: str | None = field(default=None, repr=False)
    _sensors: tuple[str, ...] = field(default=(), repr=False)
    _temp_cols: tuple[str, ...] = field(default=(), repr=False)

    # ------------------------------------------------------------------ public

    def pieces(
        self,
        piece_rows: int = PIECE_ROWS,
        *,
        max_gap_samples: int = 5,
        allow_gaps: bool = False,
    ) -> Iterator[NavSamples]:
        """The recording (its chosen run) as :class:`NavSamples` pieces, in time order.

        Each piece has at most ``piece_rows`` samples (fewer where a run begins or ends
        inside a batch); memory holds one or two pieces, whatever the file's length.

        Parameters
        ----------
        piece_rows : int
            Rows read at a time.
        max_gap_samples : int
            A gap of more missing samples than this is refused unless ``allow_gaps``.
        allow_gaps : bool
            Integrate across every gap (rates: the rate is held over the gap; increments
            and counts: taken as the device reports them). Gaps are recorded in
            :attr:`gaps` either way.

        Yields
        ------
        NavSamples

        Raises
        ------
        LogError
            Naming the file, the column as the file names it and the data row: a value that
            is not a number, NaN or inf in time, a sensor or the encoder column (navigation
            cannot skip a sample), time not strictly increasing (across pieces too), a gap
            longer than ``max_gap_samples`` samples, a count column holding fractions, a
            latitude beyond ±90°, several runs and none chosen (they are listed), the chosen
            run absent or not contiguous, fewer than two samples.
        """
        piece_rows = int(piece_rows)
        if piece_rows < 1:
            raise ValueError(f"piece_rows must be at least 1, got {piece_rows}")
        self.gaps = []
        return self._pieces(piece_rows, int(max_gap_samples), bool(allow_gaps))

    # ------------------------------------------------------------------ reading

    def _src(self) -> str:
        return str(self.path)

    def _foreign(self, canon: str) -> str:
        return self.names.get(canon, canon)

    def _needed(self) -> list[str]:
        canon = [TIME, *self._sensors, *self._temp_cols]
        for flag, cols in (
            (self.has_temp_out, (TEMP_OUT,)),
            (self.has_table, (TABLE,)),
            (self.has_ref, REF_TRACK),
            (self.has_ref_heading, (REF_HEADING,)),
            (RUN in self.names, (RUN,)),
        ):
            if flag:
                canon.extend(cols)
        return list(dict.fromkeys(self._foreign(c) for c in canon))

    def _raw(self, piece_rows: int) -> Iterator[tuple[int, dict[str, Any]]]:
        """(rows of the file before it, canonical column -> values) for each piece read."""
        cols = self._needed()
        inverse = {self._foreign(c): c for c in self.names}
        if self._fmt == "parquet":
            import pyarrow.parquet as pq

            try:
                pf = pq.ParquetFile(self.path, buffer_size=1 << 20, pre_buffer=False)
                batches = pf.iter_batches(batch_size=piece_rows, columns=cols)
                row = 0
                while True:
                    try:
                        batch = next(batches)
                    except StopIteration:
                        break
                    piece: dict[str, Any] = {}
                    for name in cols:
                        arr = batch.column(name)
                        canon = inverse[name]
                        if canon == RUN:
                            piece[canon] = arr.to_pandas()
                        else:
                            piece[canon] = arr.to_numpy(zero_copy_only=False)
                    n = batch.num_rows
                    del batch
                    yield row, piece
                    row += n
            except (LogError, GeneratorExit):
                raise
            except Exception as exc:  # pyarrow raises many types for a damaged file
                raise LogError(f"{self.path}: unreadable Parquet file: {exc}") from None
            return
        run_col = self.names.get(RUN)
        options = {
            "sep": self._sep,
            "usecols": cols,
            "encoding": "utf-8-sig",
            "keep_default_na": False,
            "na_values": {c: ([""] if c == run_col else list(_NA_STRINGS)) for c in cols},
            "dtype": {run_col: str} if run_col else None,
            **_CSV_READ_KW,
        }
        row = 0
        for df in _text_frames(self.path, options, piece_rows):
            yield row, {inverse[c]: df[c] for c in cols}
            row += len(df)

    def _run_pieces(self, piece_rows: int) -> Iterator[tuple[int, dict[str, Any]]]:
        """The rows of the chosen (or only) run: (rows of the file before, columns)."""
        has_run = RUN in self.names
        target = self.run
        if target is not None and not has_run:
            raise LogError(
                f"{self.path}: run {target!r} chosen, but the file has no {RUN!r} column "
                "(it is one recording: leave --run out)"
            )
        seen = ended = False
        current: object = None
        total = 0
        for row, piece in self._raw(piece_rows):
            if not has_run:
                n = len(piece[TIME])
                if n:
                    total += n
                    yield row, piece
                continue
            run = piece.pop(RUN)
            n = len(run)
            if n == 0:
                continue
            if isinstance(run.dtype, pd.CategoricalDtype):  # Parquet dictionary: by codes
                codes = run.cat.codes.to_numpy()
                uniques = [str(u) for u in run.cat.categories]
            else:
                codes, found = pd.factorize(run, sort=False, use_na_sentinel=True)
                uniques = [str(u) for u in found]
            empty = codes < 0
            if empty.any():
                pos = int(np.argmax(empty))
                raise LogError(
                    f"{self.path}: {_label(RUN, self.names)}, data row {row + pos + 1}: empty "
                    f"run name ({_ROWS})"
                )
            if target is None:
                present = np.unique(codes) if len(uniques) > 1 else [0]
                if current is None:
                    current = uniques[present[0]]
                if len(present) > 1 or uniques[present[0]] != current:
                    raise self._several_runs()
                total += n
                yield row, piece
                continue
            mask = codes == (uniques.index(target) if target in uniques else -2)
            if not mask.any():
                ended = ended or seen
                continue
            idx = np.flatnonzero(mask)
            a, b = int(idx[0]), int(idx[-1]) + 1
            resumes = None
            if ended or (seen and a != 0):
                resumes = a
            elif b - a != idx.size:
                hole = a + int(np.argmin(mask[a:b]))
                resumes = hole + int(np.argmax(mask[hole:b]))
            if resumes is not None:
                raise LogError(
                    f"{self.path}: {_label(RUN, self.names)}, data row {row + resumes + 1}: run "
                    f"{target!r} resumes after rows of other runs; a run's rows must be "
                    f"contiguous to be navigated ({_ROWS})"
                )
            seen = True
            ended = b < n
            if a == 0 and b == n:
                total += n
                yield row, piece
            else:
                total += b - a
                yield row + a, {k: _rows(v, a, b) for k, v in piece.items()}
        if has_run and target is not None and not seen:
            runs, count = self._scan_runs()
            raise LogError(
                f"{self.path}: no run {target!r} in column {self._foreign(RUN)!r}; the file "
                f"holds {self._runs_text(runs, count)}"
            )
        if total < 2:
            raise LogError(
                f"{self.path}: {total} sample(s); navigating needs at least two"
                + (f" (run {target!r})" if target is not None else "")
            )

    def _scan_runs(self, most: int = 10) -> tuple[list[str], int]:
        """The first ``most`` run names in file order, and how many runs there are."""
        col = self._foreign(RUN)
        seen: dict[str, None] = {}
        if self._fmt == "parquet":
            import pyarrow.parquet as pq

            pf = pq.ParquetFile(self.path)
            for batch in pf.iter_batches(batch_size=PIECE_ROWS, columns=[col]):
                for v in pd.unique(batch.column(0).to_pandas().astype(object)):
                    seen.setdefault(str(v), None)
        else:
            options = {
                "sep": self._sep,
                "usecols": [col],
                "dtype": {col: str},
                "keep_default_na": False,
                "na_values": {col: [""]},
                "encoding": "utf-8-sig",
            }
            for df in _text_frames(self.path, options, PIECE_ROWS):
                for v in pd.unique(df[col]):
                    seen.setdefault(str(v), None)
        names = list(seen)
        return names[:most], len(names)

    @staticmethod
    def _runs_text(runs: list[str], count: int) -> str:
        more = f", ... ({count} in all)" if count > len(runs) else ""
        return f"{count} run(s): {', '.join(map(repr, runs))}{more}"

    def _several_runs(self) -> LogError:
        runs, count = self._scan_runs()
        return LogError(
            f"{self.path}: column {self._foreign(RUN)!r} holds {self._runs_text(runs, count)}; "
            'choose one with --run (or run = "..." in the mapping)'
        )

    # ------------------------------------------------------------------ converting

    def _float(self, values: Any, canon: str, row: int) -> np.ndarray:
        """One column of a piece as float64 (no copy for a float64 column)."""
        if isinstance(values, np.ndarray):
            if values.dtype == np.float64:
                return values
            if values.dtype.kind in "iuf":
                return values.astype(np.float64)
            if values.dtype.kind in "mM":
                raise LogError(
                    f"{self.path}: {_label(canon, self.names)} holds dates/times, not numbers"
                    + ("; write time as a number (s, ms or us)" if canon == TIME else "")
                )
            values = pd.Series(values)
        elif values.dtype.kind in "mM":
            raise LogError(f"{self.path}: {_label(canon, self.names)} holds dates, not numbers")
        return as_float(values, self._src(), canon, self.names, copy=False, first_row=row)

    def _times(self, values: Any, row: int) -> tuple[np.ndarray, np.ndarray | None]:
        """Seconds, and the integer ticks when the time column is integer (exact intervals)."""
        per_second = TIME_UNITS[self.mapping.time_unit] if self.mapping is not None else 1.0
        arr = values.to_numpy() if isinstance(values, pd.Series) else values
        if arr.dtype.kind in "iu":
            ticks = arr.astype(np.int64)
            t = ticks.astype(np.float64)
            return (t / per_second if per_second != 1.0 else t), ticks
        t = self._float(values, TIME, row)
        _check_finite(t, self._src(), TIME, self.names, False, "time must be finite", row)
        return (t / per_second if per_second != 1.0 else t), None

    def _sensor_block(
        self, piece: dict[str, Any], row: int, dt: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Increments [rad], [m/s], each (n, 3), C order, in r (``axes`` applied)."""
        n = dt.shape[0]
        out = (np.empty((n, 3), dtype=np.float64), np.empty((n, 3), dtype=np.float64))
        axes = _parse_axes(self.mapping.axes) if self.mapping is not None else _IDENTITY
        dest = {fa: (i, sign) for i, (fa, sign) in enumerate(axes)}  # file axis -> ours
        for j, canon in enumerate(self._sensors):
            x = self._float(piece[canon], canon, row)
            _check_finite(
                x, self._src(), canon, self.names, False,
                "navigation cannot skip a sample", row,
            )  # fmt: skip
            if self.kind == "counts":
                frac = x != np.rint(x)
                if frac.any():
                    pos = int(np.argmax(frac))
                    raise LogError(
                        f"{self.path}: {_label(canon, self.names)}, data row {row + pos + 1}: "
                        f"value {float(x[pos])!r} is not a whole number of counts; the mapping "
                        "gives [weights] (integer counts per interval): is this column a rate? "
                        f"({_ROWS})"
                    )
            i, sign = dest[j % 3]
            col = out[j // 3][:, i]
            k = self.to_si[CHANNELS[j]] * sign  # exact: the sign only flips
            if self.kind == "rates":
                np.multiply(x * dt, k, out=col)  # the mean rate over the interval, times it
            elif k == 1.0:
                col[:] = x
            else:
                np.multiply(x, k, out=col)
        return out

    def _pieces(
        self, piece_rows: int, max_gap_samples: int, allow_gaps: bool
    ) -> Iterator[NavSamples]:
        raw = self._run_pieces(piece_rows)
        nominal = 1.0 / self.rate_hz if self.rate_hz else None
        held: list[tuple[int, dict[str, Any], np.ndarray, np.ndarray | None]] = []
        if nominal is None:  # the median interval of the first NOMINAL_SAMPLES samples
            count = 0
            for row, piece in raw:
                t, ticks = self._times(piece[TIME], row)
                held.append((row, piece, t, ticks))
                count += t.shape[0]
                if count >= NOMINAL_SAMPLES:
                    break
            t0 = np.concatenate([h[2] for h in held])[:NOMINAL_SAMPLES]
            d0 = np.diff(t0)
            nominal = float(np.median(d0)) if d0.size else 0.0
            if not nominal > 0.0:
                bad = int(np.argmax(d0 <= 0)) if d0.size else 0
                self._not_increasing(t0, bad + 1, held[0][0])
        prev_t: float | None = None
        prev_ticks: int | None = None
        per_second = TIME_UNITS[self.mapping.time_unit] if self.mapping is not None else 1.0

        def timed() -> Iterator[tuple[int, dict[str, Any], np.ndarray, np.ndarray | None]]:
            yield from held
            held.clear()
            for row, piece in raw:
                yield (row, piece, *self._times(piece[TIME], row))

        for row, piece, t, ticks in timed():
            n = t.shape[0]
            dt = np.empty(n, dtype=np.float64)
            if ticks is not None:
                dt[1:] = np.diff(ticks) / per_second
                if prev_ticks is not None:
                    dt[0] = (ticks[0] - prev_ticks) / per_second
                elif prev_t is not None:
                    dt[0] = t[0] - prev_t
                else:
                    dt[0] = nominal
            else:
                dt[1:] = np.diff(t)
                dt[0] = nominal if prev_t is None else t[0] - prev_t
            first = prev_t is None
            bad = dt <= 0.0
            if first:
                bad[0] = False
            if bad.any():
                k = int(np.argmax(bad))
                before = t[k - 1] if k > 0 else prev_t
                self._not_increasing(t, k, row, before)
            long = dt > GAP_FACTOR * nominal
            if first:
                long[0] = False
            if long.any():
                for k in np.flatnonzero(long):
                    gap = Gap(
                        float(t[k]),
                        row + int(k) + 1,
                        float(dt[k]),
                        max(round(float(dt[k]) / nominal) - 1, 1),
                    )
                    self.gaps.append(gap)
                    if gap.missing_samples > max_gap_samples and not allow_gaps:
                        raise LogError(
                            f"{self.path}: {_label(TIME, self.names)}, data row {gap.row}: a "
                            f"gap of {gap.length_s:.6g} s before {gap.time_s:.10g} s (about "
                            f"{gap.missing_samples} samples missing at the nominal interval "
                            f"{nominal:.6g} s, more than {max_gap_samples}); pass --allow-gaps "
                            "to integrate across it (rates are held over the gap, increments "
                            f"taken as the device reports them) ({_ROWS})"
                        )
            prev_t = float(t[-1])
            prev_ticks = int(ticks[-1]) if ticks is not None else None
            yield self._samples(piece, row, t, dt)

    def _not_increasing(self, t: np.ndarray, k: int, row: int, before: float | None = None) -> None:
        prev = float(t[k - 1]) if before is None else float(before)
        raise LogError(
            f"{self.path}: {_label(TIME, self.names)}, data row {row + k + 1}: time not "
            f"strictly increasing ({float(t[k]):.10g} s after {prev:.10g} s at data row "
            f"{row + k}) ({_ROWS})"
        )

    def _samples(
        self, piece: dict[str, Any], row: int, t: np.ndarray, dt: np.ndarray
    ) -> NavSamples:
        dtheta, dv = self._sensor_block(piece, row, dt)
        axes = _parse_axes(self.mapping.axes) if self.mapping is not None else _IDENTITY
        perm = [fa for fa, _ in axes]
        table = None
        if self.has_table:
            x = self._float(piece[TABLE], TABLE, row)
            _check_finite(
                x, self._src(), TABLE, self.names, False, "the encoder angle must be finite", row
            )
            m = self.mapping
            unit = DEG_TO_RAD if m is None or m.table_unit == "deg" else 1.0
            sign = m.table_sign if m is not None else 1.0
            zero = m.table_zero_deg * DEG_TO_RAD if m is not None else 0.0
            table = x * (sign * unit)
            if zero:
                table -= zero
        temps = None
        if self.has_temps:
            cols = {}
            for canon in dict.fromkeys(self._temp_cols):
                x = self._float(piece[canon], canon, row)
                _check_finite(
                    x, self._src(), canon, self.names, True,
                    "temperatures must be finite (or empty)", row,
                )  # fmt: skip
                cols[canon] = x
            temps = np.empty((t.shape[0], 6), dtype=np.float64)
            for j, canon in enumerate(self._temp_cols):
                temps[:, j] = cols[canon]
            if perm != [0, 1, 2]:  # a temperature follows its sensor (no sign)
                temps = temps[:, [*perm, *(p + 3 for p in perm)]]
        temp_out = None
        if self.has_temp_out:
            temp_out = self._float(piece[TEMP_OUT], TEMP_OUT, row)
            _check_finite(
                temp_out, self._src(), TEMP_OUT, self.names, True,
                "temperatures must be finite (or empty)", row,
            )  # fmt: skip
        ref = None
        if self.has_ref:
            ref = np.empty((t.shape[0], 3), dtype=np.float64)
            for j, canon in enumerate(REF_TRACK):
                x = self._float(piece[canon], canon, row)
                _check_finite(
                    x, self._src(), canon, self.names, True,
                    "a reference must be finite (or empty: no reference at that sample)", row,
                )  # fmt: skip
                if j == 0:
                    _check_latitude(x, self._src(), _label(canon, self.names), row)
                ref[:, j] = x * DEG_TO_RAD if j < 2 else x
        ref_heading = None
        if self.has_ref_heading:
            x = self._float(piece[REF_HEADING], REF_HEADING, row)
            _check_finite(
                x, self._src(), REF_HEADING, self.names, True,
                "a reference must be finite (or empty)", row,
            )  # fmt: skip
            ref_heading = x * DEG_TO_RAD
        return NavSamples(
            t=t,
            dt=dt,
            dtheta=dtheta,
            dv=dv,
            first_row=row + 1,
            table=table,
            temps=temps,
            temp_out=temp_out,
            ref=ref,
            ref_heading=ref_heading,
        )


def _rows(values: Any, a: int, b: int) -> Any:
    """Rows ``a:b`` (positions) of a column: an ndarray or a Series."""
    return values.iloc[a:b] if isinstance(values, pd.Series) else values[a:b]


def _check_latitude(lat_deg: np.ndarray, source: str, label: str, row: int) -> None:
    with np.errstate(invalid="ignore"):
        bad = np.abs(lat_deg) > 90.0
    if bad.any():
        pos = int(np.argmax(bad))
        raise LogError(
            f"{source}: {label}, data row {row + pos + 1}: latitude {float(lat_deg[pos])!r}° is "
            f"beyond ±90° ({_ROWS})"
        )


# --------------------------------------------------------------------------- opening


def _header(
    p: Path, fmt: str, mapping: NavMapping | None
) -> tuple[list[str], str | None, int | None]:
    """The file's column names, its separator (text) and its row count (Parquet)."""
    if fmt == "parquet":
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


def _resolve(p: Path, cols: list[str], mapping: NavMapping | None) -> dict[str, str]:
    """Canonical name -> the file's column, for every canonical column the file has."""
    names = {c: c for c in cols if c in NAV_CANONICAL}
    if mapping is None:
        return names
    rename = mapping.rename()
    missing = [c for c in rename if c not in cols]
    if missing:
        raise LogError(
            f"{p}: column(s) {', '.join(map(repr, missing))} named in the mapping are not in "
            f"the file (columns found: {_quoted(cols)})"
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


def _quoted(cols: list[str], most: int = 20) -> str:
    return ", ".join(map(repr, cols[:most])) + (", ..." if len(cols) > most else "")


def _kind(
    p: Path, names: dict[str, str], mapping: NavMapping | None, cols: list[str]
) -> tuple[Kind, tuple[str, ...]]:
    """How the file gives the IMU's output, and its six sensor columns (canonical names)."""
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
            f"{', '.join((*DTHETA, *DVEL))} (columns found: {_quoted(cols)}); a foreign log "
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
    if mapping is not None and mapping.weights:
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
    if meta.get("heading_deg") is not None:
        out["heading_deg"] = _meta_number(meta, "heading_deg", mp)
    if "noise" in meta:
        noise = meta["noise"]
        if not isinstance(noise, Mapping):
            raise LogError(f"{mp}: noise must be an object of noise densities")
        out["noise"] = {
            k: _meta_number(noise, k, f"{mp}: noise")
            for k in ("gyro_noise_density", "accel_noise_density", "gyro_bias_rw", "accel_bias_rw")
            if k in noise
        }
        for k, v in out["noise"].items():
            if v < 0:
                raise LogError(f"{mp}: noise.{k}: {v!r} is negative")
    if meta.get("utc_start") is not None:
        out["utc_start"] = parse_utc(meta["utc_start"], f"{mp}: utc_start")
    return out


def _units(
    kind: Kind, mapping: NavMapping | None, meta: dict[str, Any] | None, mp: str
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
            assert mapping is not None
            w = channel_unit(mapping.weights, ch)
            assert w is not None
            units[ch] = f"{w}/count"
            to_si[ch] = parse_weight(w, sensor, key=f"weights.{ch}")
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


def open_nav_log(
    path: str | os.PathLike[str],
    mapping: NavMapping | None = None,
    run: str | None = None,
    *,
    fmt: str | None = None,
) -> NavLog:
    """Open a recorded-navigation log: its header and metadata, not its data.

    Parameters
    ----------
    path : path-like
        ``.csv``, ``.tsv`` or ``.parquet``.
    mapping : NavMapping, optional
        How to read a foreign log; None for canonical column names.
    run : str, optional
        Which run to read (overrides ``mapping.run``); needed when the file's ``run``
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
    p = Path(path)
    f = format_of(p, fmt)
    if not p.exists():
        raise LogError(f"{p}: no such file")
    if p.is_dir():
        raise LogError(f"{p}: is a folder, not a log file")
    cols, sep, n_rows = _header(p, f, mapping)
    names = _resolve(p, cols, mapping)
    if TIME not in names:
        raise LogError(
            f"{p}: no time column {TIME!r} (columns found: {_quoted(cols)}); a foreign log "
            "names its time column in the mapping (time = ..., time_unit = ...)"
        )
    kind, sensors = _kind(p, names, mapping, cols)
    meta = read_meta(p)
    mp = f"{p}.meta.json"
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
    chosen = run if run is not None else (mapping.run if mapping is not None else None)
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


# --------------------------------------------------------------------------- track


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
    """

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    source: Path
    used: int
    skipped: dict[str, int] = field(default_factory=dict)


_NMEA_SUFFIXES = (".nmea", ".txt", ".gga", ".log")


def read_track(path: str | os.PathLike[str], utc_start: str | datetime | None = None) -> Track:
    """Read a reference track: a table (CSV, TSV, Parquet) or NMEA GGA sentences.

    Parameters
    ----------
    path : path-like
        A table with ``time_s, ref_lat_deg, ref_lon_deg, ref_h_m`` [s, deg, deg, m]
        (suffix ``.csv``, ``.tsv``, ``.parquet``) or NMEA text (suffix ``.nmea``, ``.txt``,
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
    want = (TIME, *REF_TRACK)
    missing = [c for c in want if c not in df.columns]
    if missing:
        raise LogError(
            f"{p}: track column(s) {', '.join(map(repr, missing))} missing (columns found: "
            f"{_quoted([str(c) for c in df.columns])}); a track table has "
            f"{', '.join(want)}"
        )
    if len(df) < 1:
        raise LogError(f"{p}: no data rows (only a header)")
    arrays = {}
    for c in want:
        x = as_float(df[c], str(p), c)
        _check_finite(x, str(p), c, None, False, "a track value must be finite")
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
    )


def _read_nmea(p: Path, utc_start: str | datetime | None) -> Track:
    import pynmea2

    if utc_start is None:
        raise LogError(
            f"{p}: NMEA GGA sentences carry the UTC time of day only: pass --track-utc-start "
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
