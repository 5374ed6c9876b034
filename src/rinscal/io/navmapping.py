"""The recorded-navigation log (``rinscal navigate --log``) and its column mapping.

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

Sidecar metadata ``<log>.meta.json`` (:func:`rinscal.io.metadata.read_meta`) may give ``rate_hz``,
``units`` (of rate columns), ``site`` = ``{"lat_deg", "lon_deg", "h_m"}``, ``heading_deg``,
``noise`` = ``{"gyro_noise_density" [rad/√s], "accel_noise_density" [m/s²/√Hz]}`` (and
optionally ``"gyro_bias_rw"`` [rad/s/√s], ``"accel_bias_rw"`` [m/s²/√s]) and
``utc_start`` (ISO 8601, the UTC of ``time_s`` = 0, for NMEA reference tracks).

A reference track may also be a separate file, read by
:func:`rinscal.io.track.read_track`: a table with ``time_s, ref_lat_deg, ref_lon_deg,
ref_h_m`` or NMEA GGA sentences.

Row numbers in messages are data rows of the file: 1-based, the header not counted.

This module holds the mapping (:class:`NavMapping`, :func:`read_nav_mapping`,
:func:`parse_weight`); the log is opened by :func:`rinscal.io.navopen.open_nav_log` and read
piece by piece through :class:`rinscal.io.navlog.NavLog`.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from rinscal.errors import ConfigError
from rinscal.io.mapping import (
    channel_unit,
    check_mapping_basics,
    mapping_keys,
    mapping_toml,
)
from rinscal.schema import (
    CHANNELS,
    NAV_CANONICAL,
    TEMP_IN,
    TIME,
)
from rinscal.units import ARCSEC_TO_RAD, DEG_TO_RAD, G0, check_sensor_unit

__all__ = [
    "ANGLE_WEIGHT_UNITS",
    "VELOCITY_WEIGHT_UNITS",
    "NavMapping",
    "parse_weight",
    "read_nav_mapping",
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

_ROWS = "data row numbers are 1-based, header not counted"
_GROUPS = {"gyro": CHANNELS[:3], "accel": CHANNELS[3:]}
_AXES = ("x", "y", "z")
_IDENTITY = ((0, 1.0), (1, 1.0), (2, 1.0))
_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_WEIGHT_RE = re.compile(rf"^\s*({_NUMBER})?\s*\*?\s*([^\s\d].*?)\s*$")


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
