"""One column mapping for every foreign log: calibration logs and navigation recordings.

A foreign log (other column names, a µs or ms timestamp, tab separation, one shared
temperature, rates in other units, integer pulse counts, another axis order) is read through a
:class:`ColumnMapping`, from a small TOML file (:func:`read_mapping`) or built from
command-line options (:func:`mapping_from_options`), never by editing the file. Both kinds of
log take the same file format; each key has one meaning::

    # keys for both kinds of log
    separator = "tab"            # "tab", "comma", "semicolon" or "auto" (default: by suffix)
    time = "timestamp"           # foreign time column -> time_s ...
    time_unit = "us"             # ... in s, ms or us (converted to seconds)
    temperature = "imu.temperature"   # one shared inner temperature [°C] -> temp_in

    [columns]                    # foreign name -> canonical name
    "imu.gyro.x" = "gyro_x"

    [units]                      # the unit the file's sensor values are in, by sensor
    gyro = "rad/s"               # ("gyro", "accel") or channel (rinscal.units names)
    accel = "m/s^2"

    # calibration logs (fit, select, plot, compensate, calibrate-imu) only
    relative_time = true         # shift each run to start at 0 (default false: time as given)
    drop = ["imu.status"]        # columns to leave out
    run_name = "thermal_cycle"   # the run's name when the log has no run column (default: stem)

    [scale]                      # multiply a channel by a factor after reading
    gyro_x = 1.0

    # navigation recordings (navigate --log) only
    axes = ["y", "x", "-z"]      # our x, y, z from the file's (renamed) axes, with sign
    table_sign = -1              # encoder: angle = sign * raw - zero
    table_zero_deg = 12.5        # [deg]
    table_unit = "deg"           # unit of the raw encoder column: deg or rad
    select_run = "sea_trial_2"   # which run to read when the file has several

    [weights]                    # integer counts: SI per count, by sensor or channel
    gyro = "0.1 arcsec"          # angle units: rad, deg, arcsec
    accel = "125 ug*s"           # velocity units: m/s, mm/s, ug*s, mg*s, g*s (g = 9.80665 m/s²)

What each key means, once for both:

* ``columns``: foreign name -> canonical name, of :data:`rinscal.schema.CANONICAL` for a
  calibration log, of :data:`rinscal.schema.NAV_CANONICAL` for a navigation recording (counts
  may be mapped onto ``gyro_*``/``accel_*`` or ``dtheta_*``/``dvel_*``).
* ``units``: the unit the file's sensor values are in (after ``scale``, before ``axes``),
  keyed by sensor or by channel; a channel's own entry wins. A calibration log is fitted in
  these units (they are its metadata: plot labels, the model's units, the unit check of
  ``compensate``); a navigation recording's rates are converted from them to SI.
* ``weights``: the value of one count, for sensor columns that hold integer counts per
  interval (then ``units`` is not given); all six channels need one.
* ``axes``: permutes and flips gyros, accelerometers and the per-channel temperatures alike
  (front-right-down to right-forward-up is ``["y", "x", "-z"]``); ``units`` and ``weights``
  are keyed by the file's channels before it.
* ``run_name`` names the rows of a file that has no run column; ``select_run`` chooses one run
  of a file whose run column holds several. Old mapping files say ``run`` for either: read as
  ``run_name`` for a calibration log and as ``select_run`` for a navigation recording
  (:func:`read_mapping`'s ``log_kind``).

A key of the other kind of log is refused, naming it (:func:`check_applies`). A file whose
columns already have the canonical names needs no mapping.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from rinscal.errors import ConfigError
from rinscal.schema import CANONICAL, CHANNELS, NAV_CANONICAL, TEMP_IN, TIME
from rinscal.units import (
    ARCSEC_TO_RAD,
    DEG_TO_RAD,
    G0,
    MS_TO_S,
    PULSE_UNIT,
    US_TO_S,
    check_sensor_unit,
)

__all__ = [
    "ANGLE_WEIGHT_UNITS",
    "LOG_KINDS",
    "SEPARATORS",
    "TIME_UNITS",
    "VELOCITY_WEIGHT_UNITS",
    "ColumnMapping",
    "LogKind",
    "channel_unit",
    "check_applies",
    "mapping_from_options",
    "parse_weight",
    "read_mapping",
]

#: The kinds of log a mapping reads.
LogKind = Literal["calibration", "navigation"]
LOG_KINDS: tuple[str, ...] = ("calibration", "navigation")
#: Keys that only one kind of log uses (the others apply to both).
ONLY_FOR: dict[str, tuple[str, ...]] = {
    "calibration": ("relative_time", "drop", "run_name", "scale"),
    "navigation": ("weights", "axes", "table_sign", "table_zero_deg", "table_unit", "select_run"),
}
_WHAT = {"calibration": "calibration logs", "navigation": "navigation recordings"}
#: Old mapping files' ``run``: its meaning by the kind of log that read it.
_OLD_RUN = {"calibration": "run_name", "navigation": "select_run"}

#: Time units a mapping accepts, and how many of them make a second (dividing by an exact
#: integer rounds correctly: 1011327 µs -> 1.011327 s, where * 1e-6 would be off by an ulp).
TIME_UNITS: dict[str, float] = {
    "s": 1.0,
    "ms": 1.0 / MS_TO_S,
    "us": 1.0 / US_TO_S,
    "µs": 1.0 / US_TO_S,
}
#: Separator names a mapping accepts.
SEPARATORS: dict[str, str | None] = {
    "auto": None,
    "tab": "\t",
    "comma": ",",
    "semicolon": ";",
    "\t": "\t",
    ",": ",",
    ";": ";",
}
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
_CHANNEL_GROUPS = {"gyro": CHANNELS[:3], "accel": CHANNELS[3:]}
_AXES = ("x", "y", "z")
#: (file axis index, sign) of our x, y, z when the file's axes are ours.
IDENTITY_AXES: tuple[tuple[int, float], ...] = ((0, 1.0), (1, 1.0), (2, 1.0))
_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_WEIGHT_RE = re.compile(rf"^\s*({_NUMBER})?\s*\*?\s*([^\s\d].*?)\s*$")
_TABLES = ("columns", "scale", "units", "weights")
#: Keys whose value is a string.
_STRINGS = (
    "time",
    "time_unit",
    "separator",
    "temperature",
    "table_unit",
    "run_name",
    "select_run",
)


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


def parse_axes(axes: Any) -> tuple[tuple[int, float], ...]:
    """(file axis index, sign) of our x, y, z from a mapping's ``axes``.

    Raises
    ------
    ConfigError
        Unless ``axes`` is a signed permutation of x, y, z that is a rotation (no mirror).
    """
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


def _sensor_key(table: str, key: Any) -> str:
    """``gyro``/``accel`` of a ``units``/``weights``/``scale`` key; ConfigError otherwise."""
    if key not in CHANNELS and key not in _CHANNEL_GROUPS:
        raise ConfigError(
            f"{table}: {key!r} is not a channel, 'gyro' or 'accel' ({', '.join(CHANNELS)})"
        )
    return str(key).partition("_")[0]


@dataclass(frozen=True)
class ColumnMapping:
    """How to read a foreign log, calibration log or navigation recording (keys and their one
    meaning in the module docstring).

    Parameters
    ----------
    columns : mapping of str to str
        Foreign column name -> canonical name (:data:`rinscal.schema.CANONICAL` or
        :data:`rinscal.schema.NAV_CANONICAL`, by the kind of log).
    time : str, optional
        Foreign time column, renamed to ``time_s``.
    time_unit : {"s", "ms", "us"}
        Unit of the time column; it is converted to seconds.
    separator : {"auto", "tab", "comma", "semicolon"}, optional
        Field separator of a text file; ``None`` (default) follows the suffix
        (``.tsv`` tab, ``.csv`` comma); ``"auto"`` guesses from the header line.
    temperature : str, optional
        A single foreign temperature column [°C] shared by all sensors, renamed to ``temp_in``.
    units : mapping of str to str
        ``"gyro"``/``"accel"`` or a channel -> the unit (a :data:`rinscal.units.SENSOR_UNITS`
        name) the file's values are in, after ``scale``, before ``axes``.
    relative_time : bool
        Calibration logs: shift each run's time so that its first sample is at 0 s, e.g. for
        an absolute µs timestamp. Off by default: time is read as given (only its unit
        converted).
    drop : tuple of str
        Calibration logs: foreign columns to leave out.
    run_name : str, optional
        Calibration logs: the run's name for a log without a run column (default: the
        file's stem).
    scale : mapping of str to float
        Calibration logs: canonical channel -> factor multiplying its values after reading.
    weights : mapping of str to str
        Navigation recordings: ``"gyro"``/``"accel"`` or a channel -> the weight of one count,
        e.g. ``"0.1 arcsec"``, ``"125 ug*s"`` (:func:`parse_weight`); all six channels need
        one. With weights the six sensor columns hold integer counts per interval.
    axes : tuple of 3 str
        Navigation recordings: our x, y, z from the file's axes, each with an optional sign.
    table_sign : {1.0, -1.0}
        Navigation recordings: sign of the encoder column.
    table_zero_deg : float [deg]
        Navigation recordings: encoder zero, subtracted after the sign:
        ``angle = sign · raw − zero``.
    table_unit : {"deg", "rad"}
        Navigation recordings: unit of the raw encoder column (``table_zero_deg`` is always
        in degrees).
    select_run : str, optional
        Navigation recordings: which run to read when the file's run column has several.
    """

    columns: Mapping[str, str] = field(default_factory=dict)
    time: str | None = None
    time_unit: str = "s"
    separator: str | None = None
    temperature: str | None = None
    units: Mapping[str, str] = field(default_factory=dict)
    relative_time: bool = False
    drop: tuple[str, ...] = ()
    run_name: str | None = None
    scale: Mapping[str, float] = field(default_factory=dict)
    weights: Mapping[str, str] = field(default_factory=dict)
    axes: tuple[str, str, str] = ("x", "y", "z")
    table_sign: float = 1.0
    table_zero_deg: float = 0.0
    table_unit: str = "deg"
    select_run: str | None = None

    def __post_init__(self) -> None:
        for name in _TABLES:
            object.__setattr__(self, name, dict(getattr(self, name)))
        object.__setattr__(self, "drop", tuple(self.drop))
        parse_axes(self.axes)
        object.__setattr__(self, "axes", tuple(self.axes))
        known = (*CANONICAL, *(c for c in NAV_CANONICAL if c not in CANONICAL))
        for foreign, canon in self.columns.items():
            if not isinstance(foreign, str) or canon not in known:
                raise ConfigError(
                    f"columns: {foreign!r} -> {canon!r}: {canon!r} is not a canonical column "
                    f"(canonical: {', '.join(known)})"
                )
        self._check_basics()
        for ch, k in self.scale.items():
            if ch not in CHANNELS:
                raise ConfigError(f"scale: {ch!r} is not a channel ({', '.join(CHANNELS)})")
            if isinstance(k, bool) or not isinstance(k, int | float) or not math.isfinite(k):
                raise ConfigError(f"scale.{ch}: {k!r} is not a finite number")
        for key, unit in self.units.items():
            sensor = _sensor_key("units", key)
            if not isinstance(unit, str):
                raise ConfigError(f"units.{key}: {unit!r} is not a unit name")
            try:
                check_sensor_unit(sensor, unit)
            except ValueError as exc:
                raise ConfigError(f"units.{key}: {exc}") from None
        for key, w in self.weights.items():
            parse_weight(w, _sensor_key("weights", key), key=f"weights.{key}")
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
        self._check_table()
        for key in ("run_name", "select_run"):
            v = getattr(self, key)
            if v is not None and (not isinstance(v, str) or not v):
                raise ConfigError(f"{key}: {v!r} is not a run name")

    def _check_basics(self) -> None:
        """No two foreign columns onto one canonical name; a known time unit and separator."""
        targets = list(self.columns.values())
        targets += [c for c, k in ((TIME, self.time), (TEMP_IN, self.temperature)) if k]
        dup = sorted({t for t in targets if targets.count(t) > 1})
        if dup:
            raise ConfigError(f"columns: several foreign columns map to {', '.join(dup)}")
        if self.time_unit not in TIME_UNITS:
            raise ConfigError(
                f"time_unit: {self.time_unit!r} is not one of {', '.join(TIME_UNITS)}"
            )
        if self.separator is not None and self.separator not in SEPARATORS:
            raise ConfigError(
                f"separator: {self.separator!r} is not one of auto, tab, comma, semicolon"
            )

    def _check_table(self) -> None:
        """The encoder keys: a sign of ±1, a finite zero [deg], a unit of deg or rad."""
        if self.table_sign not in (1, -1) or isinstance(self.table_sign, bool):
            raise ConfigError(f"table_sign: {self.table_sign!r} is not 1 or -1")
        object.__setattr__(self, "table_sign", float(self.table_sign))
        zero = self.table_zero_deg
        if isinstance(zero, bool) or not isinstance(zero, int | float) or not math.isfinite(zero):
            raise ConfigError(f"table_zero_deg: {zero!r} is not a finite number [deg]")
        object.__setattr__(self, "table_zero_deg", float(zero))
        if self.table_unit not in ("deg", "rad"):
            raise ConfigError(f"table_unit: {self.table_unit!r} is not 'deg' or 'rad'")

    @classmethod
    def from_dict(
        cls,
        data: Mapping[str, Any],
        source: str = "<mapping>",
        log_kind: LogKind = "calibration",
    ) -> ColumnMapping:
        """Build a mapping from parsed TOML (or any dict of the same keys).

        Parameters
        ----------
        data : mapping
            Keys as in the module docstring; an old file's ``run`` is read as ``run_name``
            (calibration log) or ``select_run`` (navigation recording).
        source : str
            Named in error messages.
        log_kind : {"calibration", "navigation"}
            The kind of log the mapping reads: keys of the other kind are refused.

        Raises
        ------
        ConfigError
            Naming ``source`` and the offending key.
        """
        if log_kind not in LOG_KINDS:
            raise ConfigError(f"log_kind: {log_kind!r} is not one of {', '.join(LOG_KINDS)}")
        data = dict(data)
        if "run" in data:
            new = _OLD_RUN[log_kind]
            if new in data:
                raise ConfigError(
                    f"{source}: run and {new} both given; {new} is its name now: drop run"
                )
            data[new] = data.pop("run")
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ConfigError(
                f"{source}: unknown key(s) {', '.join(unknown)} (known: {', '.join(sorted(known))})"
            )
        for key in _TABLES:
            if key in data and not isinstance(data[key], Mapping):
                raise ConfigError(f"{source}: {key} must be a table")
        if "drop" in data:
            drop = data["drop"]
            if isinstance(drop, str):
                drop = [drop]
            if not isinstance(drop, list | tuple) or not all(isinstance(d, str) for d in drop):
                raise ConfigError(f"{source}: drop must be a list of column names")
            data["drop"] = tuple(drop)
        for key in _STRINGS:
            if key in data and not isinstance(data[key], str):
                raise ConfigError(f"{source}: {key} must be a string, got {data[key]!r}")
        if "relative_time" in data and not isinstance(data["relative_time"], bool):
            raise ConfigError(f"{source}: relative_time must be true or false")
        try:
            mapping = cls(**data)
            check_applies(mapping, log_kind)
        except ConfigError as exc:
            raise ConfigError(f"{source}: {exc}") from None
        return mapping

    def unit_of(self, channel: str) -> str | None:
        """Unit of ``channel`` declared in :attr:`units`, or ``None``."""
        return channel_unit(self.units, channel)

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


def check_applies(mapping: ColumnMapping, log_kind: LogKind) -> None:
    """Refuse a mapping that sets a key, or maps onto a column, that ``log_kind`` lacks.

    Parameters
    ----------
    mapping : ColumnMapping
        The mapping.
    log_kind : {"calibration", "navigation"}
        The kind of log it is about to read.

    Raises
    ------
    ConfigError
        Naming the keys (or columns) that belong to the other kind of log.
    """
    other = next(k for k in LOG_KINDS if k != log_kind)
    default = ColumnMapping()
    keys = [k for k in ONLY_FOR[other] if getattr(mapping, k) != getattr(default, k)]
    if keys:
        raise ConfigError(
            f"{', '.join(keys)}: {'apply' if len(keys) > 1 else 'applies'} to "
            f"{_WHAT[other]} only, not to {_WHAT[log_kind]}"
        )
    canonical = CANONICAL if log_kind == "calibration" else NAV_CANONICAL
    for foreign, canon in mapping.columns.items():
        if canon not in canonical:
            raise ConfigError(
                f"columns: {foreign!r} -> {canon!r}: {canon!r} is not a column of "
                f"{_WHAT[log_kind]} (canonical: {', '.join(canonical)})"
            )
    if log_kind == "navigation":
        for key, unit in mapping.units.items():
            if unit == PULSE_UNIT:
                sensor = key.partition("_")[0]
                raise ConfigError(
                    f"units.{key}: counts are given by their weight: [weights] {sensor} = "
                    f"{'0.1 arcsec' if sensor == 'gyro' else '125 ug*s'} (say), not a unit"
                )


def channel_unit(units: Mapping[str, Any], channel: str) -> str | None:
    """Unit of ``channel`` in a units table keyed by channel or by sensor, or ``None``.

    Parameters
    ----------
    units : mapping
        ``{"gyro_x": "deg/h", ...}`` and/or ``{"gyro": "rad/s", "accel": "m/s^2"}`` (a
        mapping's ``[units]``, a log's ``meta["units"]``); a channel's own entry wins.
    channel : str
        A sensor channel, e.g. ``"accel_z"``.
    """
    if channel in units:
        return str(units[channel])
    for group, chans in _CHANNEL_GROUPS.items():
        if channel in chans and group in units:
            return str(units[group])
    return None


def read_mapping(path: str | os.PathLike[str], log_kind: LogKind = "calibration") -> ColumnMapping:
    """Read a :class:`ColumnMapping` from a TOML file, for one kind of log.

    Parameters
    ----------
    path : path-like
        The TOML file (keys as in the module docstring).
    log_kind : {"calibration", "navigation"}
        The kind of log it reads: an old file's ``run`` becomes ``run_name`` (calibration) or
        ``select_run`` (navigation); keys of the other kind are refused.

    Raises
    ------
    ConfigError
        If the file is missing, a folder, not TOML, or has an unknown or invalid key (named
        with the file).
    """
    p = Path(path)
    try:
        with p.open("rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"{p}: mapping file not found") from None
    except IsADirectoryError:
        raise ConfigError(f"{p}: is a folder, not a mapping file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{p}: not a valid TOML mapping file: {exc}") from None
    return ColumnMapping.from_dict(data, source=str(p), log_kind=log_kind)


def mapping_from_options(
    base: ColumnMapping | None = None,
    *,
    columns: Sequence[str] = (),
    time: str | None = None,
    time_unit: str | None = None,
    separator: str | None = None,
    temperature: str | None = None,
    run_name: str | None = None,
    drop: Sequence[str] = (),
    scale: Sequence[str] = (),
    relative_time: bool | None = None,
) -> ColumnMapping | None:
    """Build (or override) a mapping from command-line style options.

    Parameters
    ----------
    base : ColumnMapping, optional
        A mapping read from a file; the options override or extend it.
    columns : sequence of str
        ``"FOREIGN=canonical"`` pairs.
    time, time_unit, separator, temperature, run_name : str, optional
        As in :class:`ColumnMapping`.
    drop : sequence of str
        Foreign columns to leave out.
    scale : sequence of str
        ``"channel=factor"`` pairs.
    relative_time : bool, optional
        Override the mapping's ``relative_time`` (None: keep it; off without a mapping).

    Returns
    -------
    ColumnMapping or None
        ``None`` when there is neither a base nor any option (read the log as canonical).

    Raises
    ------
    ConfigError
        For a malformed pair or value, naming the argument (``columns=``, ``scale=``).
    """

    def pairs(items: Sequence[str], arg: str) -> dict[str, str]:
        out = {}
        for item in items:
            key, sep, value = item.rpartition("=")
            if not sep or not key or not value:
                raise ConfigError(f"{arg}={item!r} is not of the form NAME=VALUE")
            out[key] = value
        return out

    scale_values: dict[str, float] = {}
    for ch, text in pairs(scale, "scale").items():
        try:
            scale_values[ch] = float(text)
        except ValueError:
            raise ConfigError(f"scale={ch + '=' + text!r}: {text!r} is not a number") from None
    given = {
        "time": time,
        "time_unit": time_unit,
        "separator": separator,
        "temperature": temperature,
        "run_name": run_name,
        "relative_time": relative_time,
    }
    given = {k: v for k, v in given.items() if v is not None}
    if base is None and not (given or columns or drop or scale):
        return None
    base = base or ColumnMapping()
    extra = pairs(columns, "columns")
    # an option mapping a column onto a canonical name replaces the file's entry for it
    kept = {f: c for f, c in base.columns.items() if c not in extra.values() and f not in extra}
    return dataclasses.replace(
        base,
        columns={**kept, **extra},
        drop=(*base.drop, *drop),
        scale={**base.scale, **scale_values},
        **given,
    )
