"""Column mappings: how a foreign log (other column names, units, separator) is read.

A foreign log (other column names, a µs or ms timestamp, tab separation, one shared
temperature) is read through a :class:`ColumnMapping`, from a small TOML file
(:func:`read_mapping`) or built from command-line options (:func:`mapping_from_options`),
never by editing the file::

    # tofupilot_mapping.toml
    separator = "tab"            # "tab", "comma", "semicolon" or "auto"
    time = "timestamp"           # foreign time column ...
    time_unit = "us"             # ... in s, ms or us
    relative_time = true         # shift each run to start at 0 (default false: time as given)
    temperature = "imu.temperature"   # one shared inner temperature -> temp_in
    drop = ["imu.status"]        # columns to leave out
    run = "thermal_cycle"        # run name when the log has no run column (default: file stem)

    [columns]                    # foreign name -> canonical name
    "imu.gyro.x" = "gyro_x"

    [scale]                      # optional: multiply a channel by a factor after reading
    gyro_x = 1.0

    [units]                      # optional: units of the channels (rinscal.units names)
    gyro = "rad/s"
    accel = "m/s^2"

The recorded-navigation reader's mapping (:class:`rinscal.io.navmapping.NavMapping`) shares
the checks of :func:`check_mapping_basics` and the TOML reading of :func:`mapping_toml`.
"""

from __future__ import annotations

import dataclasses
import math
import os
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rinscal.errors import ConfigError
from rinscal.schema import (
    CANONICAL,
    CHANNELS,
    TEMP_IN,
    TIME,
)
from rinscal.units import MS_TO_S, US_TO_S, check_sensor_unit

__all__ = [
    "SEPARATORS",
    "TIME_UNITS",
    "ColumnMapping",
    "channel_unit",
    "check_mapping_basics",
    "mapping_from_options",
    "mapping_keys",
    "mapping_toml",
    "read_mapping",
]

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
_CHANNEL_GROUPS = {"gyro": CHANNELS[:3], "accel": CHANNELS[3:]}


@dataclass(frozen=True)
class ColumnMapping:
    """How to read a foreign log into the canonical schema.

    Parameters
    ----------
    columns : mapping of str to str
        Foreign column name -> canonical name (see :data:`rinscal.schema.CANONICAL`).
    time : str, optional
        Foreign time column, renamed to ``time_s``.
    time_unit : {"s", "ms", "us"}
        Unit of the time column; it is converted to seconds.
    relative_time : bool
        Shift each run's time so that its first sample is at 0 s, e.g. for an absolute µs
        timestamp. Off by default: time is read as given (only its unit converted).
    separator : {"auto", "tab", "comma", "semicolon"}, optional
        Field separator of a text file; ``None`` (default) follows the suffix
        (``.tsv`` tab, ``.csv`` comma); ``"auto"`` guesses from the header line.
    temperature : str, optional
        A single foreign temperature column shared by all sensors, renamed to ``temp_in``.
    run : str, optional
        Run name for a log without a run column (default: the file's stem).
    scale : mapping of str to float
        Canonical channel -> factor multiplying its values after reading.
    drop : tuple of str
        Foreign columns to leave out.
    units : mapping of str to str
        Canonical channel (or ``"gyro"``/``"accel"`` for all three) -> unit name of the
        values after scaling, e.g. ``"rad/s"``; used for plot labels.
    """

    columns: Mapping[str, str] = field(default_factory=dict)
    time: str | None = None
    time_unit: str = "s"
    relative_time: bool = False
    separator: str | None = None
    temperature: str | None = None
    run: str | None = None
    scale: Mapping[str, float] = field(default_factory=dict)
    drop: tuple[str, ...] = ()
    units: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "columns", dict(self.columns))
        object.__setattr__(self, "scale", dict(self.scale))
        object.__setattr__(self, "drop", tuple(self.drop))
        object.__setattr__(self, "units", dict(self.units))
        for foreign, canon in self.columns.items():
            if canon not in CANONICAL:
                raise ConfigError(
                    f"columns: {foreign!r} -> {canon!r}: {canon!r} is not a canonical column "
                    f"(canonical: {', '.join(CANONICAL)})"
                )
        check_mapping_basics(self)
        for ch, k in self.scale.items():
            if ch not in CHANNELS:
                raise ConfigError(f"scale: {ch!r} is not a channel ({', '.join(CHANNELS)})")
            if isinstance(k, bool) or not isinstance(k, int | float) or not math.isfinite(k):
                raise ConfigError(f"scale.{ch}: {k!r} is not a finite number")
        for key, unit in self.units.items():
            if key not in CHANNELS and key not in _CHANNEL_GROUPS:
                raise ConfigError(
                    f"units: {key!r} is not a channel, 'gyro' or 'accel' ({', '.join(CHANNELS)})"
                )
            if not isinstance(unit, str):
                raise ConfigError(f"units.{key}: {unit!r} is not a unit name")
            try:
                check_sensor_unit(key.partition("_")[0], unit)  # gyro_x and gyro -> gyro
            except ValueError as exc:
                raise ConfigError(f"units.{key}: {exc}") from None
        if self.run is not None and (not isinstance(self.run, str) or not self.run):
            raise ConfigError(f"run: {self.run!r} is not a run name")

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "<mapping>") -> ColumnMapping:
        """Build a mapping from parsed TOML (or any dict of the same keys).

        Parameters
        ----------
        data : mapping
            Keys as in the module docstring.
        source : str
            Named in error messages.

        Raises
        ------
        ConfigError
            Naming ``source`` and the offending key.
        """
        kw = mapping_keys(cls, data, source, tables=("columns", "scale", "units"))
        if "drop" in kw:
            drop = kw["drop"]
            if isinstance(drop, str):
                drop = [drop]
            if not isinstance(drop, list | tuple) or not all(isinstance(d, str) for d in drop):
                raise ConfigError(f"{source}: drop must be a list of column names")
            kw["drop"] = tuple(drop)
        for key in ("time", "time_unit", "separator", "temperature", "run"):
            if key in kw and not isinstance(kw[key], str):
                raise ConfigError(f"{source}: {key} must be a string, got {kw[key]!r}")
        if "relative_time" in kw and not isinstance(kw["relative_time"], bool):
            raise ConfigError(f"{source}: relative_time must be true or false")
        try:
            return cls(**kw)
        except ConfigError as exc:
            raise ConfigError(f"{source}: {exc}") from None

    def unit_of(self, channel: str) -> str | None:
        """Unit of ``channel`` declared in :attr:`units`, or ``None``."""
        return channel_unit(self.units, channel)

    def foreign_columns(self) -> list[str]:
        """Every foreign column the mapping names (and so the file must have)."""
        cols = list(self.columns)
        cols += [c for c in (self.time, self.temperature) if c is not None]
        return cols


def mapping_keys(
    cls: type, data: Mapping[str, Any], source: str, tables: Sequence[str]
) -> dict[str, Any]:
    """A mapping's keys as a dict for ``cls``, unknown keys and non-table tables refused.

    Parameters
    ----------
    cls : dataclass type
        The mapping class (its fields are the known keys).
    data : mapping
        Parsed TOML.
    source : str
        Named in error messages.
    tables : sequence of str
        Keys whose values must be tables.
    """
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - known)
    if unknown:
        raise ConfigError(
            f"{source}: unknown key(s) {', '.join(unknown)} (known: {', '.join(sorted(known))})"
        )
    kw = dict(data)
    for key in tables:
        if key in kw and not isinstance(kw[key], Mapping):
            raise ConfigError(f"{source}: {key} must be a table")
    return kw


def check_mapping_basics(mapping: Any) -> None:
    """The checks every mapping shares: no two foreign columns onto one canonical name, a
    known time unit and separator.

    Parameters
    ----------
    mapping : ColumnMapping or rinscal.io.navmapping.NavMapping
        Anything with ``columns``, ``time``, ``temperature``, ``time_unit``, ``separator``.

    Raises
    ------
    ConfigError
        Naming the key.
    """
    targets = list(mapping.columns.values())
    if mapping.time is not None:
        targets.append(TIME)
    if mapping.temperature is not None:
        targets.append(TEMP_IN)
    dup = sorted({t for t in targets if targets.count(t) > 1})
    if dup:
        raise ConfigError(f"columns: several foreign columns map to {', '.join(dup)}")
    if mapping.time_unit not in TIME_UNITS:
        raise ConfigError(f"time_unit: {mapping.time_unit!r} is not one of {', '.join(TIME_UNITS)}")
    if mapping.separator is not None and mapping.separator not in SEPARATORS:
        raise ConfigError(
            f"separator: {mapping.separator!r} is not one of auto, tab, comma, semicolon"
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


def read_mapping(path: str | os.PathLike[str]) -> ColumnMapping:
    """Read a :class:`ColumnMapping` from a TOML file.

    Parameters
    ----------
    path : path-like
        The TOML file (keys as in the module docstring).

    Raises
    ------
    ConfigError
        If the file is missing, not TOML, or has an unknown or invalid key (named).
    """
    p = Path(path)
    return ColumnMapping.from_dict(mapping_toml(p), source=str(p))


def mapping_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The parsed TOML of a mapping file (either reader's).

    Raises
    ------
    ConfigError
        If the file is missing, a folder or not TOML (named).
    """
    p = Path(path)
    try:
        with p.open("rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"{p}: mapping file not found") from None
    except IsADirectoryError:
        raise ConfigError(f"{p}: is a folder, not a mapping file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{p}: not a valid TOML mapping file: {exc}") from None


def mapping_from_options(
    base: ColumnMapping | None = None,
    *,
    columns: Sequence[str] = (),
    time: str | None = None,
    time_unit: str | None = None,
    separator: str | None = None,
    temperature: str | None = None,
    run: str | None = None,
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
    time, time_unit, separator, temperature, run : str, optional
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
        For a malformed pair or value, naming the option.
    """

    def pairs(items: Sequence[str], option: str) -> dict[str, str]:
        out = {}
        for item in items:
            key, sep, value = item.rpartition("=")
            if not sep or not key or not value:
                raise ConfigError(f"{option}: {item!r} is not of the form NAME=VALUE")
            out[key] = value
        return out

    scale_values: dict[str, float] = {}
    for ch, text in pairs(scale, "--scale").items():
        try:
            scale_values[ch] = float(text)
        except ValueError:
            raise ConfigError(f"--scale: {ch}={text!r} is not a number") from None
    given = {
        "time": time,
        "time_unit": time_unit,
        "separator": separator,
        "temperature": temperature,
        "run": run,
        "relative_time": relative_time,
    }
    given = {k: v for k, v in given.items() if v is not None}
    if base is None and not (given or columns or drop or scale):
        return None
    base = base or ColumnMapping()
    extra = pairs(columns, "--col")
    # an option mapping a column onto a canonical name replaces the file's entry for it
    kept = {f: c for f, c in base.columns.items() if c not in extra.values() and f not in extra}
    return dataclasses.replace(
        base,
        columns={**kept, **extra},
        drop=(*base.drop, *drop),
        scale={**base.scale, **scale_values},
        **given,
    )
