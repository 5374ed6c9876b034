"""CLI commands: simulate, plot."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from rinscal.cli._app import app
from rinscal.cli._options import (
    ColOpt,
    DropOpt,
    ImuOpt,
    LogArg,
    MapOpt,
    RelTimeOpt,
    RunNameOpt,
    SepOpt,
    TempColOpt,
    TimeColOpt,
    TimeUnitOpt,
    refuse_inputs,
)
from rinscal.thermal.presets import DEFAULT_PRESET

# ============================================================================ plot
# `rinscal plot LOG --out FIG.png`: the paper's Figure 3 for any calibration log.
# (Owned by the calibration-log developer; the `simulate` command lives in its own block.)

_FIGURE_SUFFIXES = (".png", ".pdf", ".svg")


def _every_instance(log: Path, instance: str | None) -> str | None:
    """``--instance`` of a plot: a flight log shows every IMU unless one is chosen."""
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal.io.tables import is_flight_log

    return "all" if instance is None and is_flight_log(log) else instance


@app.command("plot")
def plot(
    log: LogArg,
    out: Annotated[Path, typer.Option("--out", "-o", help="Figure to write (.png, .pdf or .svg).")],
    map_file: MapOpt = None,
    col: ColOpt = None,
    time_col: TimeColOpt = None,
    time_unit: TimeUnitOpt = None,
    sep: SepOpt = None,
    temp_col: TempColOpt = None,
    relative_time: RelTimeOpt = False,
    drop: DropOpt = None,
    run_name: RunNameOpt = None,
    instance: Annotated[
        str | None,
        typer.Option(
            "--instance",
            help=".ulg/.bin logs: the IMU instance N to draw (default: every instance).",
        ),
    ] = None,
    title: Annotated[str | None, typer.Option("--title", help="Figure title.")] = None,
    max_bins: Annotated[
        int,
        typer.Option("--max-bins", min=10, help="Longer runs are drawn as this many bins."),
    ] = 1000,
    dpi: Annotated[int, typer.Option("--dpi", min=30, max=1200, help="PNG resolution.")] = 120,
) -> None:
    """Draw outputs and temperatures against time per run (the paper's Figure 3)."""
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rich.progress import Progress

    from rinscal.cli._app import console, fail
    from rinscal.errors import RinscalError
    from rinscal.io.atomic import atomic_path
    from rinscal.io.foreign import read_foreign_source
    from rinscal.io.metadata import meta_path

    suffix = out.suffix.lower()
    if suffix not in _FIGURE_SUFFIXES:
        raise fail(f"{out}: unknown figure suffix {suffix or '(none)'!r}; use .png, .pdf or .svg")
    refuse_inputs(out, [log, meta_path(log)] + ([map_file] if map_file is not None else []))

    try:
        with Progress(console=console, transient=True) as progress:
            task = progress.add_task("reading log", total=3)
            src, meta = read_foreign_source(
                log,
                map_file,
                col,
                time_col,
                time_unit,
                sep,
                temp_col,
                drop,
                run_name,
                relative_time,
                instance=_every_instance(log, instance),
            )
            df = src.log
            progress.update(task, advance=1, description="drawing")

            from rinscal.report.logplot import plot_log, units_from_meta

            fig = plot_log(
                df, units=units_from_meta(meta), title=title or log.name, max_bins=max_bins
            )
            progress.update(task, advance=1, description="saving")
            with atomic_path(out) as tmp:
                fig.savefig(tmp, format=suffix.lstrip("."), dpi=dpi)
            progress.update(task, advance=1)
    except RinscalError as exc:
        raise fail(str(exc)) from None
    n_runs = df["run"].nunique()
    console.print(
        f"wrote {out} ({n_runs} run(s), {len(df):,} samples)", highlight=False, soft_wrap=True
    )


# ========================================================================== end plot


# ============================================================================ simulate
# `rinscal simulate {soak,ramp,repeat} --out FILE`: a calibration log from the thermal
# chamber + IMU simulator, its truth file and its sidecar metadata.


@app.command("simulate")
def simulate(
    protocol: Annotated[
        str,
        typer.Argument(
            metavar="PROTOCOL",
            help="Protocol: soak (Table 3), ramp (-2 -> 50 °C) or repeat (25 °C).",
        ),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Log to write (.parquet, .csv, .tsv).")],
    hours: Annotated[
        float | None,
        typer.Option(
            "--hours",
            min=0.01,
            max=72.0,
            help="Length of each run [h], 0.01-72 (soak/repeat 3 h, ramp 4.83 h).",
        ),
    ] = None,
    rate: Annotated[
        float, typer.Option("--rate", min=0.01, max=2000.0, help="Sample rate [Hz], 0.01-2000.")
    ] = 10.0,
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seed of every random number.")] = 0,
    imu: ImuOpt = DEFAULT_PRESET,
    units: Annotated[
        str | None,
        typer.Option("--units", help="physical (deg/h, µg) or pulses; overrides the config."),
    ] = None,
) -> None:
    """Simulate a thermal-chamber protocol into a calibration log, a truth file and metadata.

    Beside LOG it writes LOG's stem + '.truth' + suffix (the true thermal bias of every
    sample, in the log's unit) and LOG + '.meta.json' (units, site, offsets, seed).
    """
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from dataclasses import replace

    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from rinscal._resources import require_memory
    from rinscal.cli._app import console, fail
    from rinscal.errors import RinscalError
    from rinscal.io.metadata import meta_path, write_meta
    from rinscal.io.streaming import LogStreamWriter
    from rinscal.io.tables import format_of
    from rinscal.thermal.config import OutputConfig, load_imu
    from rinscal.thermal.presets import PRESETS
    from rinscal.thermal.protocols import PROTOCOLS, iter_protocol, log_meta, protocol_runs

    if protocol not in PROTOCOLS:
        raise fail(f"protocol must be one of {', '.join(PROTOCOLS)}; got {protocol!r}")
    if not rate > 0:
        raise fail(f"--rate must be > 0 Hz, got {rate}")
    try:
        format_of(out)
        config = load_imu(imu)
        if units is not None:
            config = replace(config, output=OutputConfig(**{**vars(config.output), "mode": units}))
        specs = protocol_runs(protocol, hours)
    except RinscalError as exc:
        raise fail(str(exc)) from None
    out.parent.mkdir(parents=True, exist_ok=True)
    truth_path = out.with_name(f"{out.stem}.truth{out.suffix}")
    refuse_inputs(out, [] if imu in PRESETS else [Path(imu)], also=[truth_path, meta_path(out)])
    n_samples = sum(int(s.duration_s * rate) for s in specs)
    # measured: about 0.27 GB plus 1.25 kB per sample of the longest run (one run in memory)
    longest = max(int(s.duration_s * rate) for s in specs)
    try:
        require_memory(
            0.27e9 + 1250.0 * longest,
            f"simulate {protocol} at {rate:g} Hz ({longest:,} samples in the longest run)",
            "lower --rate or --hours",
        )
    except RinscalError as exc:
        raise fail(str(exc)) from None
    console.print(
        f"simulating {protocol}: {len(specs)} run(s), {n_samples:,} samples at {rate:g} Hz, "
        f"seed {seed}",
        highlight=False,
    )
    runs = []
    try:
        with (
            LogStreamWriter(out, validate=False) as log_writer,
            LogStreamWriter(truth_path, validate=False) as truth_writer,
            Progress(
                TextColumn("{task.description}"),
                BarColumn(),
                TextColumn("{task.completed}/{task.total} runs"),
                TimeElapsedColumn(),
                console=console,
                transient=True,
            ) as progress,
        ):
            task = progress.add_task(f"{protocol} runs", total=len(specs))
            for run in iter_protocol(protocol, config, hours, rate, seed):
                progress.update(task, description=f"run {run.name}")
                log_writer.write(run.log)
                truth_writer.write(run.truth)
                runs.append(run.without_samples())
                progress.advance(task)
        rows = log_writer.rows
        meta = log_meta(protocol, config, rate, seed, runs)
        meta["truth_file"] = truth_path.name
        meta_file = write_meta(meta, out)
    except RinscalError as exc:
        raise fail(str(exc)) from None
    console.print(f"wrote {out} ({rows:,} rows), {truth_path.name}, {meta_file.name}")


# ======================================================================== end simulate
