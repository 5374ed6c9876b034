"""Open a log as a command names it: its mapping (or flight-log options) and metadata.

A command reads a log through a mapping file and/or options over it, gathered in one
:class:`ReadOptions` (for a PX4 ``.ulg`` or ArduPilot ``.bin`` log: ``instance``).
:func:`foreign_mapping` turns them into a :class:`rinscal.io.mapping.ColumnMapping` or
:class:`rinscal.io.flightinfo.FlightLogOptions`, :func:`foreign_meta` gives the log's
metadata, and :func:`read_foreign_source` does both and reads the log. Errors are
:class:`rinscal.errors.ConfigError` (an option that does not apply, a bad value) and
:class:`rinscal.errors.LogError`, their messages naming the argument as ``name=`` (the
command line says its flag instead).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from rinscal.errors import ConfigError
from rinscal.io.flightinfo import FlightLogOptions
from rinscal.io.mapping import ColumnMapping, mapping_from_options, read_mapping
from rinscal.io.metadata import read_meta
from rinscal.io.tables import SourceLog, is_flight_log, read_log_source
from rinscal.schema import CHANNELS

__all__ = [
    "ReadOptions",
    "flight_options",
    "foreign_mapping",
    "foreign_meta",
    "read_foreign_source",
]


@dataclass(frozen=True)
class ReadOptions:
    """How to read a calibration log: a mapping file and the options over it.

    Parameters
    ----------
    map_file : Path, optional
        A mapping TOML file (:func:`rinscal.io.mapping.read_mapping`).
    col : tuple of str
        ``"FOREIGN=canonical"`` pairs, over the file's ``[columns]``.
    time_col : str, optional
        Foreign time column.
    time_unit : {"s", "ms", "us"}, optional
        Its unit.
    sep : {"auto", "tab", "comma", "semicolon"}, optional
        Field separator.
    temp_col : str, optional
        One shared inner temperature column [°C] (becomes ``temp_in``).
    drop : tuple of str
        Foreign columns to leave out.
    run_name : str, optional
        The run's name for a log without a run column.
    relative_time : bool
        Shift each run's time to start at 0 s (a mapping file may also ask for it).
    instance : str, optional
        PX4 ``.ulg`` / ArduPilot ``.bin`` logs: the IMU instance ``"0"``, ``"1"`` ... or
        ``"all"``; the table options are refused there.
    """

    map_file: Path | None = None
    col: tuple[str, ...] = ()
    time_col: str | None = None
    time_unit: str | None = None
    sep: str | None = None
    temp_col: str | None = None
    drop: tuple[str, ...] = ()
    run_name: str | None = None
    relative_time: bool = False
    instance: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "col", tuple(self.col or ()))
        object.__setattr__(self, "drop", tuple(self.drop or ()))
        if self.map_file is not None:
            object.__setattr__(self, "map_file", Path(self.map_file))

    def table_options(self) -> dict[str, Any]:
        """Argument name -> value of every option that applies to a table only."""
        flight = ("run_name", "instance")
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name not in flight}


def foreign_mapping(
    log: Path, options: ReadOptions | None = None
) -> ColumnMapping | FlightLogOptions | None:
    """The column mapping a mapping file and/or options give (None for a canonical log).

    For a PX4 ``.ulg`` or ArduPilot ``.bin`` ``log``: the reading options (``instance``,
    ``run_name``) instead; the table options are refused there, as ``instance`` is for a
    table.

    Raises
    ------
    ConfigError
        For an option that does not apply to the log, or a malformed one (named as
        ``name=``).
    """
    options = options or ReadOptions()
    if is_flight_log(log):
        return flight_options(log, options.instance, options.run_name, options.table_options())
    if options.instance is not None:
        raise ConfigError(
            f"{log}: instance={options.instance!r} applies to PX4 .ulg and ArduPilot .bin logs only"
        )
    base = read_mapping(options.map_file) if options.map_file is not None else None
    return mapping_from_options(
        base,
        columns=options.col,
        time=options.time_col,
        time_unit=options.time_unit,
        separator=options.sep,
        temperature=options.temp_col,
        run_name=options.run_name,
        drop=options.drop,
        relative_time=True if options.relative_time else None,
    )


def flight_options(
    log: Path, instance: str | None, run_name: str | None, table: dict[str, Any]
) -> FlightLogOptions:
    """Reading options of a flight log from ``instance``/``run_name``; table options refused.

    Parameters
    ----------
    log : Path
        The flight log (named in messages).
    instance : str, optional
        As given: ``"0"``, ``"1"`` ... or ``"all"``.
    run_name : str, optional
        The run's name.
    table : dict
        Argument name -> value of every table option (:meth:`ReadOptions.table_options`);
        any that is set is refused.

    Raises
    ------
    ConfigError
        Naming the table options given, or a malformed ``--instance``.
    """
    given = [k for k, v in table.items() if v]
    if given:
        names = ", ".join(k + "=" for k in given)
        raise ConfigError(
            f"{log}: {names} apply to CSV/TSV/Parquet tables; a ULog or DataFlash log is read "
            "as it is (choose the IMU with instance=)"
        )
    which: int | str | None = None
    if instance is not None:
        text = instance.strip().lower()
        if text == "all":
            which = "all"
        elif text.isdigit():
            which = int(text)
        else:
            raise ConfigError(f"instance={instance!r} is not an IMU instance 0, 1, 2 ... or 'all'")
    return FlightLogOptions(instance=which, run=run_name)  # type: ignore[arg-type]


def foreign_meta(log: Path, mapping: ColumnMapping | FlightLogOptions | None) -> dict[str, Any]:
    """A log's metadata: its sidecar ``.meta.json``, units from the mapping where it has none.

    ``meta["log"]`` is the log's file name. A flight log's own metadata (units, autopilot,
    instance, device ids, see :meth:`rinscal.io.flightinfo.FlightLogInfo.meta`) comes first;
    the sidecar's keys win.
    """
    if isinstance(mapping, FlightLogOptions):
        # deferred on purpose: the flight-log readers compile numba kernels (and load pyulog or
        # pymavlink), which a table never needs
        from rinscal.io.flightlog import scan_flight_log

        return scan_flight_log(log).meta(mapping) | dict(read_meta(log) or {})
    meta = dict(read_meta(log) or {})
    if "units" not in meta and mapping is not None:
        units = {c: u for c in CHANNELS if (u := mapping.unit_of(c))}
        if units:
            meta["units"] = units
    meta.setdefault("log", log.name)
    return meta


def read_foreign_source(
    log: Path, options: ReadOptions | None = None
) -> tuple[SourceLog, dict[str, Any]]:
    """Read a log through a mapping file and/or options: the log as read, and its metadata.

    See :func:`foreign_mapping` and :func:`foreign_meta`. ``.log`` of the result is the
    canonical frame; ``.raw`` the file's own table, to write it back.

    Raises
    ------
    ConfigError, LogError
        For an option that does not apply or a log that cannot be read (named).
    """
    mapping = foreign_mapping(log, options)
    src = read_log_source(log, mapping)
    return src, foreign_meta(log, mapping)
