"""Open a log as the command line names it: its mapping (or flight-log options) and metadata.

A command reads a log through a mapping file and/or options (``--map``, ``--col``,
``--time-col``, ``--sep`` ...; ``--instance`` for a PX4 ``.ulg`` or ArduPilot ``.bin`` log).
:func:`foreign_mapping` turns them into a :class:`rinscal.io.mapping.ColumnMapping` or
:class:`rinscal.io.flightinfo.FlightLogOptions`, :func:`foreign_meta` gives the log's
metadata, and :func:`read_foreign_source` does both and reads the log. Errors are
:class:`rinscal.errors.ConfigError` (an option that does not apply, a bad value) and
:class:`rinscal.errors.LogError`, their messages naming the option as the user wrote it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rinscal.errors import ConfigError
from rinscal.io.flightinfo import FlightLogOptions
from rinscal.io.mapping import ColumnMapping, mapping_from_options, read_mapping
from rinscal.io.metadata import read_meta
from rinscal.io.tables import SourceLog, is_flight_log, read_log_source
from rinscal.schema import CHANNELS

__all__ = ["flight_options", "foreign_mapping", "foreign_meta", "read_foreign_source"]


def foreign_mapping(
    map_file: Path | None = None,
    col: list[str] | None = None,
    time_col: str | None = None,
    time_unit: str | None = None,
    sep: str | None = None,
    temp_col: str | None = None,
    drop: list[str] | None = None,
    run_name: str | None = None,
    relative_time: bool = False,
    *,
    instance: str | None = None,
    log: Path | None = None,
) -> ColumnMapping | FlightLogOptions | None:
    """The column mapping a mapping file and/or options give (None for a canonical log).

    ``relative_time`` turns the mapping's relative time on (a mapping file may also ask for it).
    For a PX4 ``.ulg`` or ArduPilot ``.bin`` ``log``: the reading options (``--instance``,
    ``--run-name``) instead; the table options are refused there, as ``--instance`` is for a
    table.

    Raises
    ------
    ConfigError
        For an option that does not apply to the log, or a malformed one (named).
    """
    if log is not None and is_flight_log(log):
        table = {"map": map_file, "col": col, "time-col": time_col, "time-unit": time_unit}
        table |= {"sep": sep, "temp-col": temp_col, "drop": drop, "relative-time": relative_time}
        return flight_options(log, instance, run_name, table)
    if instance is not None:
        raise ConfigError(f"{log}: --instance applies to PX4 .ulg and ArduPilot .bin logs only")
    base = read_mapping(map_file) if map_file is not None else None
    return mapping_from_options(
        base,
        columns=col or (),
        time=time_col,
        time_unit=time_unit,
        separator=sep,
        temperature=temp_col,
        run=run_name,
        drop=drop or (),
        relative_time=True if relative_time else None,
    )


def flight_options(
    log: Path, instance: str | None, run_name: str | None, table: dict[str, Any]
) -> FlightLogOptions:
    """Reading options of a flight log from ``--instance``/``--run-name``; table options refused.

    Parameters
    ----------
    log : Path
        The flight log (named in messages).
    instance : str, optional
        ``--instance`` as given: ``"0"``, ``"1"`` ... or ``"all"``.
    run_name : str, optional
        ``--run-name``.
    table : dict
        Option name (without ``--``) -> value of every table option; any that is set is
        refused.

    Raises
    ------
    ConfigError
        Naming the table options given, or a malformed ``--instance``.
    """
    given = [k for k, v in table.items() if v]
    if given:
        flags = ", ".join("--" + k for k in given)
        raise ConfigError(
            f"{log}: {flags} apply to CSV/TSV/Parquet tables; a ULog or DataFlash log is read "
            "as it is (choose the IMU with --instance)"
        )
    which: int | str | None = None
    if instance is not None:
        text = instance.strip().lower()
        if text == "all":
            which = "all"
        elif text.isdigit():
            which = int(text)
        else:
            raise ConfigError(
                f"--instance must be an IMU instance 0, 1, 2 ... or 'all', got {instance!r}"
            )
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
    log: Path,
    map_file: Path | None = None,
    col: list[str] | None = None,
    time_col: str | None = None,
    time_unit: str | None = None,
    sep: str | None = None,
    temp_col: str | None = None,
    drop: list[str] | None = None,
    run_name: str | None = None,
    relative_time: bool = False,
    instance: str | None = None,
) -> tuple[SourceLog, dict[str, Any]]:
    """Read a log through a mapping file and/or options: the log as read, and its metadata.

    See :func:`foreign_mapping` and :func:`foreign_meta`. ``.log`` of the result is the
    canonical frame; ``.raw`` the file's own table, to write it back.

    Raises
    ------
    ConfigError, LogError
        For an option that does not apply or a log that cannot be read (named).
    """
    mapping = foreign_mapping(
        map_file,
        col,
        time_col,
        time_unit,
        sep,
        temp_col,
        drop,
        run_name,
        relative_time,
        instance=instance,
        log=log,
    )
    src = read_log_source(log, mapping)
    return src, foreign_meta(log, mapping)
