"""CLI commands: simulate, plot."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from rinscal.cli._app import app
from rinscal.cli._options import (
    ColOpt,
    DailyCycleOpt,
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
    read_options,
    refuse_inputs,
)
from rinscal.presets import DEFAULT_PRESET

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
            options = read_options(
                map_file=map_file, col=col, time_col=time_col, time_unit=time_unit, sep=sep,
                temp_col=temp_col, drop=drop, run_name=run_name, relative_time=relative_time,
                instance=_every_instance(log, instance),
            )  # fmt: skip
            src, meta = read_foreign_source(log, options)
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
            help="Protocol: soak (Table 3), ramp (-2 -> 50 °C), repeat (25 °C), "
            "multiposition (two-axis turntable: positions and rate tests at set points) or "
            "field-starts (parked cold starts at given ambients, into the folder --out).",
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
        typer.Option(
            "--units",
            help="physical (deg/h, µg) or pulses; overrides the config (multiposition: "
            "pulses unless given).",
        ),
    ] = None,
    sequence: Annotated[
        str,
        typer.Option(
            "--sequence",
            help="multiposition: 12, 18, 19 positions or a TOML file (positions = [[o, i]]).",
        ),
    ] = "19",
    set_points: Annotated[
        str | None,
        typer.Option(
            "--set-points",
            help="multiposition: chamber set points [°C], comma separated (default "
            "0,12,24,36,48; with --ramp the ramp's start and end).",
        ),
    ] = None,
    ramp: Annotated[
        bool, typer.Option("--ramp", help="multiposition: one run along a slow chamber ramp.")
    ] = False,
    dwell: Annotated[
        float,
        typer.Option("--dwell", min=0.1, help="multiposition: dwell per position [s]."),
    ] = 120.0,
    rates: Annotated[
        str | None,
        typer.Option(
            "--rates",
            help="multiposition: rate-test rates [deg/s], comma separated (default 10,50,200).",
        ),
    ] = None,
    turntable_error: Annotated[
        bool,
        typer.Option(
            "--turntable-error",
            help="multiposition: the turntable's errors (±5′ position, ±10 ppm rate).",
        ),
    ] = False,
    runs: Annotated[
        int | None,
        typer.Option("--runs", min=1, max=10000, help="field-starts: number of starts (7)."),
    ] = None,
    ambient: Annotated[
        str | None,
        typer.Option(
            "--ambient",
            help="field-starts: ambients [°C], comma separated, cycled over the runs "
            "(default 0,7,14,21,28,35,42).",
        ),
    ] = None,
    season: Annotated[
        str | None,
        typer.Option(
            "--season",
            help="field-starts: LOW,HIGH [°C]: draw each start's ambient uniformly from it "
            "(instead of --ambient).",
        ),
    ] = None,
    daily_cycle: DailyCycleOpt = None,
) -> None:
    """Simulate a thermal-chamber protocol into a calibration log, a truth file and metadata.

    Beside LOG it writes LOG's stem + '.truth' + suffix (the true thermal bias of every
    sample, in the log's unit) and LOG + '.meta.json' (units, site, offsets, seed). The
    multiposition protocol writes, instead of the first, LOG's stem + '.params.truth.csv':
    the true sensor-error parameters (biases, scale factors, nonlinear terms,
    misalignments) at each set point. field-starts (parked cold starts at given ambients,
    the table indexing four positions) writes into the folder --out start_<k>.parquet (a
    recorded-navigation log without heading), its .meta.json and start_<k>.truth.parquet.
    """
    field = {"--runs": runs, "--ambient": ambient, "--season": season,
             "--daily-cycle": daily_cycle}  # fmt: skip
    if protocol == "field-starts":
        _simulate_field_starts(rate=rate, out=out, hours=hours, seed=seed, imu=imu,
                               units=units, runs=runs, ambient=ambient, season=season,
                               daily_cycle=daily_cycle)  # fmt: skip
        return
    if any(v is not None for v in field.values()):
        # deferred: loaded when the command runs, so that `rinscal --help` starts fast
        from rinscal.cli._app import fail

        given = [k for k, v in field.items() if v is not None]
        raise fail(f"{', '.join(given)}: field-starts only, not {protocol}")
    if protocol == "multiposition":
        if hours is not None:
            # deferred: loaded when the command runs, so that `rinscal --help` starts fast
            from rinscal.cli._app import fail

            raise fail("--hours does not apply to multiposition (use --dwell, --rates)")
        _simulate_multiposition(
            out, rate, seed, imu, units, sequence, set_points, ramp, dwell, rates,
            turntable_error,
        )  # fmt: skip
        return
    given = [
        flag
        for flag, on in (
            ("--sequence", sequence != "19"),
            ("--set-points", set_points is not None),
            ("--ramp", ramp),
            ("--dwell", dwell != 120.0),
            ("--rates", rates is not None),
            ("--turntable-error", turntable_error),
        )
        if on
    ]
    if given:  # as --hours for multiposition: an option that would be ignored is refused
        from rinscal.cli._app import fail

        raise fail(f"{', '.join(given)}: multiposition only, not {protocol}")
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from dataclasses import replace

    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from rinscal._resources import require_memory
    from rinscal.cli._app import console, fail
    from rinscal.errors import RinscalError
    from rinscal.io.metadata import meta_path, truth_path, write_meta
    from rinscal.io.streaming import LogStreamWriter
    from rinscal.io.tables import format_of
    from rinscal.presets import PRESETS
    from rinscal.sim.config import OutputConfig, load_imu
    from rinscal.sim.protocols import PROTOCOLS, iter_protocol, log_meta, protocol_runs

    if protocol not in PROTOCOLS:
        raise fail(
            f"protocol must be one of {', '.join(PROTOCOLS)}, multiposition; got {protocol!r}"
        )
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
    truth_out = truth_path(out)
    refuse_inputs(out, [] if imu in PRESETS else [Path(imu)], also=[truth_out, meta_path(out)])
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
            LogStreamWriter(truth_out, validate=False) as truth_writer,
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
        meta["truth_file"] = truth_out.name
        meta_file = write_meta(meta, out)
    except RinscalError as exc:
        raise fail(str(exc)) from None
    console.print(f"wrote {out} ({rows:,} rows), {truth_out.name}, {meta_file.name}")


def _floats(text: str | None, option: str) -> tuple[float, ...] | None:
    """A comma-separated list of numbers of an option; None if not given."""
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal.cli._app import fail

    if text is None:
        return None
    try:
        out = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise fail(f"{option} must be numbers separated by commas, got {text!r}") from None
    if not out:
        raise fail(f"{option}: give at least one number")
    return out


def _simulate_multiposition(
    out: Path,
    rate: float,
    seed: int,
    imu: str,
    units: str | None,
    sequence: str,
    set_points: str | None,
    ramp: bool,
    dwell: float,
    rates: str | None,
    turntable_error: bool,
) -> None:
    """`rinscal simulate multiposition`: log, truth parameter table, metadata."""
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from dataclasses import replace

    import pandas as pd

    from rinscal.cli._app import console, fail
    from rinscal.errors import RinscalError
    from rinscal.io.metadata import meta_path, write_meta
    from rinscal.io.params import TRUTH_SUFFIX, params_path, write_params
    from rinscal.io.streaming import LogStreamWriter
    from rinscal.io.tables import format_of
    from rinscal.presets import PRESETS
    from rinscal.sim.config import OutputConfig, load_imu
    from rinscal.sim.multiposition import (
        DEFAULT_RATES_DPS,
        DEFAULT_SET_POINTS_C,
        DEFAULT_WARMUP_S,
        SEQUENCES,
        iter_multiposition,
        load_sequence,
        multiposition_meta,
    )

    points = _floats(set_points, "--set-points") or DEFAULT_SET_POINTS_C
    rate_list = _floats(rates, "--rates") or DEFAULT_RATES_DPS
    try:
        format_of(out)
        config = load_imu(imu)
        mode = units or "pulses"
        config = replace(config, output=OutputConfig(**{**vars(config.output), "mode": mode}))
        seq_name, positions = load_sequence(sequence)
    except RinscalError as exc:
        raise fail(str(exc)) from None
    truth_path = params_path(out, TRUTH_SUFFIX)
    inputs = [] if imu in PRESETS else [Path(imu)]
    inputs += [] if sequence in SEQUENCES else [Path(sequence)]
    refuse_inputs(out, inputs, also=[truth_path, meta_path(out)])
    kw = {
        "sequence": positions,
        "set_points_c": points,
        "rates_dps": rate_list,
        "dwell_s": dwell,
        "ramp": ramp,
        "turntable_error": turntable_error,
        "rate_hz": rate,
        "seed": seed,
    }
    console.print(
        f"simulating multiposition: {len(positions)} positions + rate tests at "
        f"{', '.join(f'{w:g}' for w in rate_list)} deg/s, "
        + ("a ramp" if ramp else f"{len(points)} set point(s)")
        + f", {'turntable errors' if turntable_error else 'ideal turntable'}, seed {seed}",
        highlight=False,
    )
    runs, truths = [], []
    try:
        with LogStreamWriter(out, validate=False) as writer:
            for run in iter_multiposition(config, **kw):  # type: ignore[arg-type]
                writer.write(run.log)
                truths.append(run.truth)
                runs.append(replace(run, log=run.log.iloc[:0]))
        rows = writer.rows
        write_params(pd.concat(truths, ignore_index=True), truth_path)
        meta = multiposition_meta(
            config,
            sequence=seq_name,
            positions=positions,
            set_points_c=() if ramp else points,
            rates_dps=rate_list,
            dwell_s=dwell,
            warmup_s=DEFAULT_WARMUP_S,
            turntable_error=turntable_error,
            position_error_arcmin=5.0,
            rate_error_ppm=10.0,
            rate_hz=rate,
            seed=seed,
            runs=runs,
        )
        meta["truth_file"] = truth_path.name
        meta_file = write_meta(meta, out)
    except RinscalError as exc:
        raise fail(str(exc)) from None
    console.print(f"wrote {out} ({rows:,} rows), {truth_path.name}, {meta_file.name}")


def _simulate_field_starts(
    *,
    rate: float,
    out: Path,
    hours: float | None,
    seed: int,
    imu: str,
    units: str | None,
    runs: int | None,
    ambient: str | None,
    season: str | None,
    daily_cycle: float | None,
) -> None:
    """`rinscal simulate field-starts --out DIR`: parked cold starts, each a recording, its
    metadata and its truth."""
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from rinscal.cli._app import console, fail
    from rinscal.errors import RinscalError
    from rinscal.sim.fieldstarts import (
        DEFAULT_AMBIENTS_C,
        field_start_files,
        field_starts,
        simulate_field_starts,
    )

    if units is not None:
        raise fail("--units: not for field-starts (the IMU's own output mode decides)")
    if ambient is not None and season is not None:
        raise fail("give --ambient or --season, not both")
    if out.exists() and not out.is_dir():
        raise fail(f"--out {out}: field-starts writes into a folder; that is a file")
    ambients = _floats(ambient, "--ambient") or DEFAULT_AMBIENTS_C
    bounds = _floats(season, "--season")
    if bounds is not None and len(bounds) != 2:
        raise fail(f"--season: give LOW,HIGH [°C], got {season!r}")
    kw = {
        "runs": 7 if runs is None else runs,
        "ambient_c": ambients,
        "hours": 4.0 if hours is None else hours,
        "rate_hz": rate,
        "seed": seed,
        "daily_cycle_c": daily_cycle or 0.0,
        "season": bounds,
    }
    try:
        starts = field_starts(**kw)  # type: ignore[arg-type]
    except RinscalError as exc:
        msg = str(exc).replace("rate_hz", "--rate").replace("ambient_c", "--ambient")
        raise fail(msg.replace("daily_cycle_c", "--daily-cycle")) from None
    existing = [p for st in starts for p in field_start_files(out, st.index) if p.exists()]
    if existing:
        raise fail(
            f"--out {out}: {existing[0].name} exists ({len(existing)} of the files to write "
            "do); field-starts never overwrites a file, give another folder"
        )
    console.print(
        f"simulating {len(starts)} parked cold start(s) of {kw['hours']:g} h at "
        f"{kw['rate_hz']:g} Hz, ambients "
        f"{', '.join(f'{s.ambient_c:g}' for s in starts)} °C, seed {seed}",
        highlight=False,
    )
    try:
        with Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            TimeElapsedColumn(),
            console=console,
            transient=True,
        ) as progress:
            task = progress.add_task("start 0", total=len(starts))

            def tick(k: int, done: float, total: float) -> None:
                progress.update(task, completed=k + done / total, description=f"start {k}")

            logs = simulate_field_starts(out, imu=imu, progress=tick, **kw)  # type: ignore[arg-type]
    except RinscalError as exc:
        raise fail(str(exc)) from None
    console.print(f"wrote {len(logs)} start(s) into {out} (start_<k>.parquet, .meta.json, "
                  ".truth.parquet)", highlight=False)  # fmt: skip


# ======================================================================== end simulate
