"""Options and guards shared by the commands: reading a foreign log, never overwriting inputs."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from rinscal.thermal.presets import PRESETS

if TYPE_CHECKING:
    from rinscal.cluster import TLSFiles
    from rinscal.flightlog import FlightLogOptions
    from rinscal.io import ColumnMapping, SourceLog

LogArg = Annotated[
    Path,
    typer.Argument(
        metavar="LOG",
        help="Calibration log (.csv, .tsv or .parquet), or a PX4 .ulg / ArduPilot .bin log.",
    ),
]
InstanceOpt = Annotated[
    str | None,
    typer.Option(
        "--instance",
        help=".ulg/.bin logs: the IMU instance N (0, 1, 2 ...) or 'all' (one run per "
        "instance); needed when the log has several IMUs.",
    ),
]
MapOpt = Annotated[
    Path | None, typer.Option("--map", help="Column mapping (TOML) for a foreign log.")
]
ColOpt = Annotated[
    list[str] | None,
    typer.Option("--col", help="Map a foreign column: FOREIGN=canonical (repeatable)."),
]
TimeColOpt = Annotated[str | None, typer.Option("--time-col", help="Foreign time column.")]
TimeUnitOpt = Annotated[str | None, typer.Option("--time-unit", help="Time unit: s, ms or us.")]
SepOpt = Annotated[
    str | None, typer.Option("--sep", help="Separator: tab, comma, semicolon or auto.")
]
RelTimeOpt = Annotated[
    bool,
    typer.Option(
        "--relative-time",
        help="Shift each run's time to start at 0 s (for an absolute timestamp); "
        "off unless given: time is read as it is, only converted to seconds.",
    ),
]
TempColOpt = Annotated[
    str | None,
    typer.Option("--temp-col", help="Single shared temperature column (becomes temp_in)."),
]
DropOpt = Annotated[
    list[str] | None, typer.Option("--drop", help="Foreign column to ignore (repeatable).")
]
RunNameOpt = Annotated[
    str | None, typer.Option("--run-name", help="Run name for a log without a run column.")
]
ImuOpt = Annotated[
    str,
    typer.Option(
        "--imu",
        help=f"The simulated IMU: a preset ({', '.join(PRESETS)}) or an IMU TOML file.",
    ),
]
WorkersOpt = Annotated[
    int | None,
    typer.Option(
        "--workers",
        "-w",
        min=1,
        max=1024,
        help="Local worker processes, 1-1024 (default: one per core).",
    ),
]
PolicyOpt = Annotated[
    str,
    typer.Option(
        "--policy",
        help="Outside the training data: clamp (inputs to their range), fallback (the "
        "channel's T-only model outside the joint domain), extrapolate or error.",
    ),
]
SchedulerOpt = Annotated[
    str | None,
    typer.Option(
        "--scheduler",
        help="Run on an existing Dask cluster: its address, tcp://host:8786, or tls://host:8786 "
        "for one secured with TLS. The cluster runs the code this command sends it: use only "
        "a cluster you trust.",
    ),
]
TLSCAOpt = Annotated[
    Path | None,
    typer.Option(
        "--tls-ca-file",
        help="tls:// scheduler: the cluster's CA certificate (PEM). Without --tls-* options, "
        "Dask's configuration (distributed.comm.tls.*) gives the files.",
    ),
]
TLSCertOpt = Annotated[
    Path | None,
    typer.Option("--tls-cert", help="tls:// scheduler: this client's certificate (PEM)."),
]
TLSKeyOpt = Annotated[
    Path | None,
    typer.Option(
        "--tls-key",
        help="tls:// scheduler: this client's private key (PEM; or appended to --tls-cert).",
    ),
]
AlignLengthOpt = Annotated[
    float,
    typer.Option(
        "--align-s",
        min=60.0,
        max=7200.0,
        help="Self-alignment length [s], 60-7200: coarse (60 s) + Kalman filter.",
    ),
]
AlignStartOpt = Annotated[
    float,
    typer.Option(
        "--align-start-s",
        min=0.0,
        max=86400.0,
        help="Seconds after power-on at which the alignment starts (the unit warms before "
        "it; navigation starts at align-start-s + align-s).",
    ),
]


def cluster_options(
    workers: int | None,
    scheduler: str | None,
    tls_ca_file: Path | None,
    tls_cert: Path | None,
    tls_key: Path | None,
) -> TLSFiles | None:
    """Check ``--workers``, ``--scheduler`` and the ``--tls-*`` files together, before any work.

    Returns the certificate files given (None if none); exits with a message naming the option
    for a missing file, a certificate without a ``tls://`` scheduler, or a ``tls://``
    scheduler with no certificate in the options or Dask's configuration.
    """
    from rinscal.cli._app import fail
    from rinscal.cluster import TLSFiles, cluster_security
    from rinscal.errors import ConfigError

    if workers is not None and scheduler:
        raise fail("--workers and --scheduler exclude each other (the cluster has its own)")
    files = {"--tls-ca-file": tls_ca_file, "--tls-cert": tls_cert, "--tls-key": tls_key}
    for flag, path in files.items():
        if path is not None and not path.is_file():
            raise fail(f"{flag} {path}: no such file")
    given = [None if p is None else str(p) for p in files.values()]
    tls = TLSFiles(*given) if any(given) else None
    try:
        cluster_security(scheduler, tls)
    except ConfigError as exc:
        raise fail(str(exc)) from None
    return tls


def is_same_file(a: Path, b: Path) -> bool:
    """Whether two paths name the same file (also through links and relative paths)."""
    if a.resolve() == b.resolve():
        return True
    return a.exists() and b.exists() and os.path.samefile(a, b)


def refuse_inputs(out: Path, inputs: list[Path], also: Sequence[Path] = ()) -> None:
    """Exit with a message, before any work, if an output cannot be written whole.

    ``out`` must not be one of ``inputs``, its folder must exist, and neither ``out`` nor a
    file written beside it (``also``: a truth file, sidecar metadata) may be a folder: a
    command that is refused leaves nothing behind.
    """
    from rinscal.cli._app import fail

    for src in inputs:
        if is_same_file(out, src):
            raise fail(f"{out}: refusing to overwrite the input {src}; choose another --out")
    if not out.resolve().parent.is_dir():
        raise fail(f"{out}: folder {out.resolve().parent} does not exist")
    for path in (out, *also):
        if path.is_dir():
            raise fail(f"{path}: a folder is in the way; --out takes a file name")
        for src in inputs:
            if path != out and is_same_file(path, src):
                raise fail(f"{path}: refusing to overwrite the input {src}; choose another --out")


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
    """
    from rinscal.io import is_flight_log, mapping_from_options, read_mapping

    if log is not None and is_flight_log(log):
        table = {"map": map_file, "col": col, "time-col": time_col, "time-unit": time_unit}
        table |= {"sep": sep, "temp-col": temp_col, "drop": drop, "relative-time": relative_time}
        return flight_options(log, instance, run_name, table)
    if instance is not None:
        from rinscal.cli._app import fail

        raise fail(f"{log}: --instance applies to PX4 .ulg and ArduPilot .bin logs only")
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
    """Reading options of a flight log from ``--instance``/``--run-name``; table options refused."""
    from rinscal.cli._app import fail
    from rinscal.flightlog import FlightLogOptions

    given = [k for k, v in table.items() if v]
    if given:
        flags = ", ".join("--" + k for k in given)
        raise fail(
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
            raise fail(f"--instance must be an IMU instance 0, 1, 2 ... or 'all', got {instance!r}")
    return FlightLogOptions(instance=which, run=run_name)  # type: ignore[arg-type]


def foreign_meta(log: Path, mapping: ColumnMapping | FlightLogOptions | None) -> dict[str, Any]:
    """A log's metadata: its sidecar ``.meta.json``, units from the mapping where it has none.

    ``meta["log"]`` is the log's file name. A flight log's own metadata (units, autopilot,
    instance, device ids, see :meth:`rinscal.flightlog.FlightLogInfo.meta`) comes first; the
    sidecar's keys win.
    """
    from rinscal.flightlog import FlightLogOptions, scan_flight_log
    from rinscal.io import read_meta
    from rinscal.schema import CHANNELS

    if isinstance(mapping, FlightLogOptions):
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
    """
    from rinscal.io import read_log_source

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
