"""Options and guards shared by the commands: reading a foreign log, never overwriting inputs.

The options of a foreign log are declared here; reading it through them is
:mod:`rinscal.io.foreign` (library errors, which the commands turn into messages).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from rinscal.presets import PRESETS

if TYPE_CHECKING:
    from rinscal.cluster import TLSFiles
    from rinscal.io.foreign import ReadOptions

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
    Path | None,
    typer.Option("--map", help="Column mapping (TOML) for a foreign log (--mapping: old name)."),
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
#: ``--daily-cycle``: a daily sinusoid about the ambient of a parked cold start
#: (``navigate --scenario ... --ambient``, ``simulate field-starts``).
DailyCycleOpt = Annotated[
    float | None,
    typer.Option(
        "--daily-cycle",
        min=0.0,
        max=40.0,
        metavar="AMP_C",
        help="Amplitude [°C] of a daily sinusoid about the ambient (navigate --scenario with "
        "--ambient; simulate field-starts).",
    ),
]
#: ``--jobs`` of the commands that fan out over Dask worker processes (reproduce, study,
#: fleet fit): the cores, one single-threaded worker process each; the same name and meaning
#: (how many cores) as :data:`JobsOpt`, the threads of the other commands.
WorkerJobsOpt = Annotated[
    int | None,
    typer.Option(
        "--jobs",
        "-j",
        min=1,
        max=1024,
        help="Cores, 1-1024: one local worker process each (default: every core); the output "
        "does not depend on it. --workers/-w is its old name.",
    ),
]
#: ``--workers``: the old name of :data:`WorkerJobsOpt`'s ``--jobs``, still taken (hidden).
WorkersOpt = Annotated[
    int | None,
    typer.Option(
        "--workers",
        "-w",
        min=1,
        max=1024,
        hidden=True,
        help="Old name of --jobs (local worker processes).",
    ),
]
#: ``--jobs``: the threads a command spreads its independent work over (channels, runs,
#: navigation variants); every command that spreads work takes it under this name.
JobsOpt = Annotated[
    int | None,
    typer.Option(
        "--jobs",
        "-j",
        min=1,
        max=1024,
        help="Threads for the command's independent work, 1-1024 (default: every core); "
        "the output does not depend on it.",
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


def read_options(
    *,
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
) -> ReadOptions:
    """The reading options of a command's log (``--map``, ``--col`` ...) as one object.

    Built once, where the command receives its options; :mod:`rinscal.io.foreign` reads the
    log through it. Its errors name the arguments (``col=``), which
    :func:`rinscal.cli._app.fail` prints as the flags.
    """
    # deferred: the io layer loads pandas; `rinscal --help` must not
    from rinscal.io.foreign import ReadOptions

    return ReadOptions(
        map_file=map_file,
        col=tuple(col or ()),
        time_col=time_col,
        time_unit=time_unit,
        sep=sep,
        temp_col=temp_col,
        drop=tuple(drop or ()),
        run_name=run_name,
        relative_time=relative_time,
        instance=instance,
    )


def worker_jobs(jobs: int | None, workers: int | None) -> int | None:
    """The local worker processes of ``--jobs`` or ``--workers`` (its old name; the same
    number given twice is taken); None: every core. Exits naming both when they differ, or
    when the number is below 1 (a call from code, past typer's bounds)."""
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal.cli._app import fail

    for flag, n in (("--jobs", jobs), ("--workers", workers)):
        if n is not None and n < 1:
            raise fail(f"{flag} must be >= 1, got {n}")
    if jobs is not None and workers is not None and jobs != workers:
        raise fail(
            f"--jobs {jobs} and --workers {workers}: --workers is the old name of --jobs; "
            "give one of them"
        )
    return jobs if jobs is not None else workers


def cluster_options(
    workers: int | None,
    scheduler: str | None,
    tls_ca_file: Path | None,
    tls_cert: Path | None,
    tls_key: Path | None,
) -> TLSFiles | None:
    """Check ``--jobs`` (``workers``: its number, :func:`worker_jobs`), ``--scheduler`` and the
    ``--tls-*`` files together, before any work.

    Returns the certificate files given (None if none); exits with a message naming the option
    for a missing file, a certificate without a ``tls://`` scheduler, or a ``tls://``
    scheduler with no certificate in the options or Dask's configuration.
    """
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal.cli._app import fail
    from rinscal.cluster import TLSFiles, cluster_security
    from rinscal.errors import ConfigError

    if workers is not None and scheduler:
        raise fail("--jobs and --scheduler exclude each other (the cluster has its own workers)")
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


def input_file(src: Path) -> None:
    """Exit naming ``src`` when it is not a file to read: missing, or a folder."""
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal.cli._app import fail

    if src.is_dir():
        raise fail(f"{src}: is a folder, not a file")
    if not src.is_file():
        raise fail(f"{src}: file not found")


def is_same_file(a: Path, b: Path) -> bool:
    """Whether two paths name the same file (also through links and relative paths)."""
    if a.resolve() == b.resolve():
        return True
    return a.exists() and b.exists() and os.path.samefile(a, b)


def prepare_outputs(
    files: Sequence[tuple[str, Path]] = (), folders: Sequence[tuple[str, Path]] = ()
) -> None:
    """Check every output of a command, then create their missing folders; exit if one fails.

    The rule of every command that writes (:data:`rinscal.io.atomic.OUTPUT_RULE`): a file
    (``files``: ``(option, path)``) goes into a folder that exists, or that one of the
    command's own folder outputs creates; a folder it writes into (``folders``) is created
    with its missing parents, after every output has been checked, before any work; a path
    that goes through a file, a folder that cannot be written, a folder where a file goes,
    a file whose folder is missing is refused with a message naming the path.
    If the command then fails, the folders it created are removed again when empty
    (:func:`rinscal.cli._app.guard_os_errors`).
    """
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal.cli._app import created_folders, fail
    from rinscal.errors import OutputError
    from rinscal.io.atomic import check_output, make_folders, missing_folder_error

    todo: list[Path] = []
    try:
        for what, path in folders:
            for f in check_output(path, what=what, folder=True):
                if f not in todo:
                    todo.append(f)
        for what, path in files:  # into a folder that exists or that a folder output creates
            missing = check_output(path, what=what, folder=False)
            if any(f not in todo for f in missing):
                raise missing_folder_error(path, missing, what=what)
        todo.sort(key=lambda f: len(f.parts))  # outermost first, across outputs
        created_folders.extend(make_folders(todo))
    except OutputError as exc:
        raise fail(str(exc)) from None


def refuse_inputs(
    out: Path, inputs: list[Path], also: Sequence[Path] = (), what: str = "--out"
) -> None:
    """Exit with a message, before any work, if an output cannot be written whole.

    ``out`` must not be one of ``inputs``, and neither ``out`` nor a file written beside it
    (``also``: a truth file, sidecar metadata) may be a folder, go through a file or lie in a
    folder that does not exist (:func:`prepare_outputs`): a command that is refused leaves
    nothing behind.
    """
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal.cli._app import fail
    from rinscal.io.metadata import meta_path

    # a log's sidecar metadata is read with it: it is an input too
    inputs = [*inputs, *(meta_path(src) for src in inputs if src.suffix.lower() != ".json")]
    for src in inputs:
        if is_same_file(out, src):
            raise fail(f"{out}: refusing to overwrite the input {src}; choose another {what}")
    for path in (out, *also):
        for src in inputs:
            if path != out and is_same_file(path, src):
                raise fail(f"{path}: refusing to overwrite the input {src}; choose another {what}")
    prepare_outputs(files=[(what, p) for p in (out, *also)])
