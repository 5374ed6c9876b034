"""CLI command: navigate (a single-axis RINS scenario with thermal compensation)."""

from __future__ import annotations

import contextlib
import math
from pathlib import Path
from typing import Annotated, Any

import typer

from rinscal.cli._app import app
from rinscal.cli._options import (
    DailyCycleOpt,
    JobsOpt,
    PolicyOpt,
    input_file,
    is_same_file,
    prepare_outputs,
)
from rinscal.presets import DEFAULT_PRESET, PRESETS

#: The plant ``rinscal navigate`` runs unless ``--imu`` names another (as simulate and
#: reproduce: the paper's own IMU).
DEFAULT_IMU = DEFAULT_PRESET

_OUTPUTS = (
    "errors.csv",
    "truth.csv",
    "summary.json",
    "position_error.png",
    "trajectory.png",
    "temperatures.png",
)


@app.command("navigate")
def navigate(
    ctx: typer.Context,
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder (created if needed).")],
    scenario: Annotated[
        str | None,
        typer.Option(
            "--scenario", "-s", help="quasi-static, swing, vehicle or ramp (paper Section 5.2)."
        ),
    ] = None,
    log: Annotated[
        Path | None,
        typer.Option(
            "--log",
            help="Navigate this recording instead of a scenario (CSV, TSV or Parquet; "
            "rates, increments or counts; see docs/navigation.md).",
        ),
    ] = None,
    model: Annotated[
        list[Path] | None,
        typer.Option(
            "--model", "-m", help="Thermal model file (JSON) to compensate with; repeatable."
        ),
    ] = None,
    hours: Annotated[
        float | None,
        typer.Option(
            min=0.01,
            max=72.0,
            # rinscal.sim.scenario.DEFAULT_HOURS (a test holds them equal; importing it here
            # would cost every command 3 s of start-up)
            help="Run length [h], 0.01-72 (vehicle: driving time). Default per scenario: "
            "quasi-static 4 h, swing 2 h, vehicle 1.9 h, ramp 4.5 h.",
        ),
    ] = None,
    rate: Annotated[
        float, typer.Option("--rate", min=1.0, max=2000.0, help="IMU rate [Hz], 1-2000.")
    ] = 100.0,
    seed: Annotated[
        int, typer.Option(min=0, help="Seed of the sensor noise and turn-on offsets (≥ 0).")
    ] = 0,
    imu: Annotated[
        str | None,
        typer.Option(
            "--imu",
            help=f"The simulated IMU: a preset ({', '.join(PRESETS)}) or an IMU TOML file. "
            f"Default {DEFAULT_IMU}. With --log: the IMU whose noise the alignment filter "
            "assumes (default the log's metadata, else estimated on the window).",
        ),
    ] = None,
    imu_config: Annotated[
        Path | None,
        typer.Option("--imu-config", hidden=True, help="Old name of --imu (a TOML file)."),
    ] = None,
    rotation: Annotated[
        str, typer.Option(help="Turntable: four-position, continuous or none.")
    ] = "four-position",
    align_s: Annotated[
        float,
        typer.Option(
            "--align-s",
            min=60.0,
            max=7200.0,
            help="Self-alignment length [s], 60-7200: coarse (60 s) + Kalman filter. With "
            "--log and no --align-start-s: the longest window the finder takes.",
        ),
    ] = 600.0,
    align_start_s: Annotated[
        float | None,
        typer.Option(
            "--align-start-s",
            min=0.0,
            max=1e10,
            help="Seconds after power-on at which the alignment starts (the unit warms before "
            "it; navigation starts at align-start-s + align-s). Scenario: default 0; --log: "
            "default the earliest quiet stretch of at least 300 s.",
        ),
    ] = None,
    oracle: Annotated[
        bool, typer.Option("--oracle/--no-oracle", help="Also navigate with the true thermal bias.")
    ] = True,
    policy: PolicyOpt = "clamp",
    record: Annotated[
        Path | None,
        typer.Option(
            "--record",
            help="Scenario: also write the raw recording it navigated (.parquet, .csv or "
            ".tsv, with a .meta.json), readable by --log.",
        ),
    ] = None,
    increments: Annotated[
        bool,
        typer.Option(
            "--increments", help="--record writes increments (dtheta_*, dvel_*), not rates."
        ),
    ] = False,
    counts: Annotated[
        bool | None,
        typer.Option(
            "--counts/--no-counts",
            help="Scenario: the IMU puts out whole pulses of its [output] weights, the "
            "remainder carried, and --record writes integer counts (default: as the IMU "
            "says; ring_laser: counts of 0.1″ and 125 µg·s).",
        ),
    ] = None,
    disturbed_start: Annotated[
        float | None,
        typer.Option(
            "--disturbed-start",
            min=0.0,
            max=1e6,
            help="Scenario: people about the parked carrier for the first MIN minutes "
            "(sway and small tilt steps, carried by the truth); quasi-static or ramp.",
            metavar="MIN",
        ),
    ] = None,
    ambient: Annotated[
        float | None,
        typer.Option(
            "--ambient",
            min=-60.0,
            max=100.0,
            help="Scenario: a constant ambient [°C] instead of the scenario's chamber profile, "
            "the unit soaked at it before power-on (a parked cold start).",
            metavar="C",
        ),
    ] = None,
    daily_cycle: DailyCycleOpt = None,
    mapping: Annotated[
        Path | None,
        typer.Option(
            "--map",
            help="--log: column mapping (TOML) of a foreign recording (--mapping: old name).",
        ),
    ] = None,
    run: Annotated[
        str | None, typer.Option("--run", help="--log: the run to navigate in a log with several.")
    ] = None,
    site: Annotated[
        str | None,
        typer.Option(
            "--site",
            help="--log: the static site LAT,LON,HEIGHT [deg, deg, m] (default: the log's "
            "metadata, else the reference track's first point).",
        ),
    ] = None,
    heading: Annotated[
        float | None,
        typer.Option(
            "--heading",
            min=-360.0,
            max=360.0,
            help="--log: true heading of the body at the alignment [deg, clockwise from "
            "north], for the heading error.",
        ),
    ] = None,
    track: Annotated[
        Path | None,
        typer.Option(
            "--track",
            help="--log: reference track, CSV (time_s, ref_lat_deg, ref_lon_deg, ref_h_m) or "
            "NMEA GGA.",
        ),
    ] = None,
    track_utc_start: Annotated[
        str | None,
        typer.Option(
            "--track-utc-start",
            help="--log: UTC of the log's time 0 (ISO 8601), to place NMEA times.",
        ),
    ] = None,
    allow_gaps: Annotated[
        bool,
        typer.Option("--allow-gaps", help="--log: integrate across gaps longer than 5 samples."),
    ] = False,
    aiding: Annotated[
        str | None,
        typer.Option(
            "--aiding",
            help="--log: none (pure inertial against the track, the default) or gnss (every "
            "variant aided by the --track's positions, loosely coupled).",
        ),
    ] = None,
    gnss_sd: Annotated[
        float | None,
        typer.Option(
            "--gnss-sd",
            min=0.0,
            help="--log --track: standard deviation of each coordinate of the track's fixes "
            "that the filter assumes with --aiding gnss or in an in-motion alignment [m] "
            "(default 2).",
        ),
    ] = None,
    track_velocity_sd: Annotated[
        float | None,
        typer.Option(
            "--track-velocity-sd",
            min=0.0,
            help="--log --track: standard deviation of each velocity component of a track "
            "with ref_ve_mps, ref_vn_mps, ref_vu_mps that the filter assumes [m/s] "
            "(default 0.1).",
        ),
    ] = None,
    jobs: JobsOpt = None,
) -> None:
    """Navigate a single-axis RINS, simulated (--scenario) or recorded (--log), and report
    its position error.

    Writes errors.csv (position error per variant over time), truth.csv, summary.json and
    the figures position_error.png, trajectory.png and temperatures.png into --out, and
    prints per variant the maximum position error and the heading, pitch and roll error
    the alignment handed over.
    """

    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal.calibration.modelfile import POLICIES
    from rinscal.cli._app import console, fail
    from rinscal.errors import RinscalError

    if scenario is None and log is None:
        raise fail("give --scenario (a simulated run) or --log (a recording)")
    if scenario is not None and log is not None:
        raise fail("give either --scenario (a simulated run) or --log (a recording), not both")
    if log is not None:
        extra = {"--record": record, "--hours": hours, "--imu-config": imu_config,
                 "--counts/--no-counts": counts, "--disturbed-start": disturbed_start,
                 "--ambient": ambient, "--daily-cycle": daily_cycle}  # fmt: skip
        given = [k for k, v in extra.items() if v is not None] + (["--increments"] * increments)
        given += [
            f"--{p.replace('_', '-')}"
            for p in ("rate", "seed", "rotation", "oracle")
            if ctx.get_parameter_source(p).name != "DEFAULT"  # type: ignore[union-attr]
        ]
        if given:
            raise fail(f"{', '.join(given)}: only with --scenario, not with --log")
        if gnss_sd is not None and track is None:
            raise fail("--gnss-sd: only with --track (its fixes' σ, for --aiding gnss or an "
                       "in-motion alignment)")  # fmt: skip
        if track_velocity_sd is not None and track is None:
            raise fail("--track-velocity-sd: only with --track (its velocities' σ)")
        _navigate_log(
            log, out, list(model or []), policy, mapping=mapping, run=run, site=site,
            heading=heading, track=track, track_utc_start=track_utc_start, align_s=align_s,
            align_start_s=align_start_s, imu=imu, allow_gaps=allow_gaps, jobs=jobs,
            aiding=({} if aiding is None else {"aiding": aiding})
            | ({} if gnss_sd is None else {"gnss_sd_m": gnss_sd})
            | ({} if track_velocity_sd is None else {"track_velocity_sd": track_velocity_sd}),
        )  # fmt: skip
        return
    assert scenario is not None
    given = [k for k, v in {"--map": mapping, "--run": run, "--site": site,
             "--heading": heading, "--track": track, "--track-utc-start": track_utc_start,
             "--aiding": aiding, "--gnss-sd": gnss_sd,
             "--track-velocity-sd": track_velocity_sd}.items()
             if v is not None] + (["--allow-gaps"] * allow_gaps)  # fmt: skip
    if given:
        raise fail(f"{', '.join(given)}: only with --log, not with --scenario")
    if increments and record is None:
        raise fail("--increments says how --record writes; give --record too")
    if daily_cycle is not None and ambient is None:
        raise fail("--daily-cycle is a cycle about --ambient; give --ambient too")
    align_start_s = 0.0 if align_start_s is None else align_start_s

    if imu is not None and imu_config is not None:
        raise fail("give the IMU once: --imu (--imu-config is its old name)")
    imu_spec = str(imu_config) if imu_config is not None else (imu or DEFAULT_IMU)
    imu_file = None if imu_spec in PRESETS else Path(imu_spec)
    if imu_file is not None and imu_file.suffix.lower() != ".toml" and not imu_file.exists():
        raise fail(f"--imu {imu_spec!r} is neither a preset ({', '.join(PRESETS)}) nor a TOML file")
    models = list(model or [])
    inputs = [*models, *([imu_file] if imu_file is not None else [])]
    for src in inputs:
        input_file(src)
    out_paths = [out / name for name in _OUTPUTS]
    from rinscal.io.metadata import meta_path

    if record is not None:
        from rinscal.io.tables import FORMATS

        if record.suffix.lower() not in FORMATS:
            raise fail(f"--record {record}: give a .parquet, .csv or .tsv file name")
        for dst in out_paths:
            if is_same_file(record, dst) or record.resolve() == dst.resolve():
                raise fail(f"--record {record}: that is one of the outputs in --out; name another")
        out_paths += [record, meta_path(record)]
    for dst in out_paths:
        for src in inputs:
            if is_same_file(dst, src):
                raise fail(f"{dst}: refusing to overwrite the input {src}; choose another --out")
    if not (math.isfinite(rate) and rate > 0):
        raise fail(f"--rate must be > 0 Hz, got {rate}")
    if not (math.isfinite(align_s) and align_s > 0):
        raise fail(f"--align-s must be > 0 s, got {align_s}")
    if not (math.isfinite(align_start_s) and align_start_s >= 0):
        raise fail(f"--align-start-s must be >= 0 s, got {align_start_s}")
    if disturbed_start is not None and not (math.isfinite(disturbed_start) and disturbed_start > 0):
        raise fail(f"--disturbed-start must be > 0 min, got {disturbed_start}")
    if policy not in POLICIES:
        raise fail(f"--policy must be one of {', '.join(POLICIES)}, got {policy!r}")
    # every output checked, then its folders created, before the run; none left if it fails
    recorded = [] if record is None else [("--record", record), ("--record", meta_path(record))]
    prepare_outputs(files=recorded, folders=[("--out", out)])

    try:
        # deferred: navigation loads numba kernels; `rinscal --help` must not
        from rinscal.sim.workflow import navigate_scenario

        with _progress() as progress:  # type: ignore[attr-defined]
            tasks: list[Any] = []  # the bar starts with the first tick, which knows the total

            def tick(done: float, total: float) -> None:
                if not tasks:
                    tasks.append(progress.add_task(f"navigating {scenario}", total=total))
                progress.update(tasks[0], completed=done)

            nav = navigate_scenario(
                scenario, imu=imu_spec, models=models, hours=hours, rate_hz=rate, seed=seed,
                rotation=rotation, align_s=align_s, align_start_s=align_start_s, oracle=oracle,
                policy=policy, record=record, increments=increments, quantise=counts,
                disturbed_start_min=disturbed_start, ambient_c=ambient,
                daily_cycle_c=daily_cycle or 0.0, progress=tick, n_jobs=jobs,
            )  # fmt: skip
    except RinscalError as exc:
        raise fail(str(exc)) from None
    cfg, summary = nav.config, nav.summary
    _save(nav, out, jobs)
    console.print(
        f"navigation from {cfg.nav_start_s:g} s after power-on "
        f"(alignment from {cfg.align_start_s:g} s, {align_s:g} s long)",
        highlight=False,
        soft_wrap=True,
    )
    if "disturbance" in summary:
        d = summary["disturbance"]
        console.print(
            f"disturbed start: people about the carrier until {d['end_s']:g} s "
            f"({d['sway_bursts']} sway bursts, {d['tilt_steps']} tilt steps)",
            highlight=False,
            soft_wrap=True,
        )
    if record is not None:
        out_kind = summary.get("output", {})
        how = (
            f"integer counts of {out_kind['weights']['gyro']} and {out_kind['weights']['accel']}"
            if out_kind.get("quantised") and not increments
            else ("increments" if increments else "rates")
        )
        console.print(
            f"recorded the raw IMU output to {record} ({how})", highlight=False, soft_wrap=True
        )
    _print_variants(summary)


def _save(nav: object, out: Path, jobs: int | None, ahead: _FiguresAhead | None = None) -> None:
    """errors.csv, truth.csv, summary.json and the figures, each written atomically (the
    figures drawn while the CSV files are formatted, on ``jobs`` threads; those drawn ahead
    by ``ahead`` taken as they are)."""
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal.report.nav_plots import navigation_figures, save_navigation

    if ahead is None:
        save_navigation(nav, out, n_jobs=jobs)  # type: ignore[arg-type]
        return

    def figures(nav: Any) -> dict[str, Any]:
        drawn = ahead.drawn()  # waited for first: one figure drawn at a time
        return {**navigation_figures(nav, skip=tuple(drawn)), **drawn}

    nav.save(out, figures=figures, n_jobs=jobs)  # type: ignore[attr-defined]


class _FiguresAhead:
    """Figures' work done ahead on a thread of its own, with more than one thread (``jobs``,
    None: every core); nothing with one.

    :meth:`start`: import the figures' module (matplotlib, about 0.3 s of one core), once,
    :func:`_save` then finding it imported; called when the reading has begun, as its
    pyarrow, numpy and numba work leaves the interpreter free most of the time (before it,
    the command's own start-up holds it). :meth:`temperatures`: draw ``temperatures.png``
    from the first pass's frame while the second pass navigates (its threads run kernels
    that release the interpreter). :meth:`drawn`: the PNGs drawn so far, by file name. A
    failure is left to :func:`_save`, which draws that figure again and says why.
    """

    def __init__(self, jobs: int | None) -> None:
        # deferred: loaded when the command runs, so that `rinscal --help` starts fast
        from concurrent.futures import ThreadPoolExecutor

        from rinscal.parallel import resolve_jobs

        self._pool = (
            ThreadPoolExecutor(max_workers=1, thread_name_prefix="rinscal-figures")
            if resolve_jobs(jobs) > 1
            else None
        )
        self._started = False
        self._temperatures: Any = None

    def start(self) -> None:
        if self._pool is not None and not self._started:
            self._started = True
            self._pool.submit(_import_figures)

    def temperatures(self, frame: Any) -> None:
        if self._pool is not None:
            self._temperatures = self._pool.submit(_temperature_png, frame)

    def drawn(self) -> dict[str, bytes]:
        if self._pool is None:
            return {}
        self._pool.shutdown(wait=True)
        if self._temperatures is None or self._temperatures.exception() is not None:
            return {}
        return {"temperatures.png": self._temperatures.result()}


def _import_figures() -> None:
    # deferred: on its own thread, ahead of _save (a failure: _save's import says why)
    with contextlib.suppress(Exception):
        import rinscal.report.nav_plots  # noqa: F401


def _temperature_png(frame: Any) -> bytes:
    """``temperatures.png`` of a navigation's temperature frame."""
    # deferred: on the figures' thread, while the second pass navigates
    from rinscal.nav.engine import figure_png
    from rinscal.report.nav_plots import plot_temperatures

    return figure_png(plot_temperatures(frame))


def _print_variants(summary: dict) -> None:
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal import units
    from rinscal.cli._app import console

    for name, v in summary["variants"].items():
        extra = ""
        if "improvement_vs_none_pct" in v:
            pct = v["improvement_vs_none_pct"]
            extra = f"  ({abs(pct):.1f} % {'less' if pct >= 0 else 'more'} than uncompensated)"
        att = v["attitude_error_at_nav_start"]
        angles = ", ".join(f'{k} {att[f"{k}_arcsec"]:+.1f}"' for k in ("heading", "pitch", "roll")
                           if f"{k}_arcsec" in att)  # fmt: skip
        console.print(
            f"{name:>14}: max position error {v['max_error_m']:10.1f} m = "
            f"{v['max_error_m'] / units.NMI_TO_M:7.3f} nmi{extra}"
            + (f"; at navigation start {angles} (arcsec)" if angles else ""),
            highlight=False,
            soft_wrap=True,
        )


def _progress() -> object:
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    from rinscal.cli._app import console

    return Progress(
        TextColumn("[progress.description]{task.description}"),
        BarColumn(),
        TextColumn("{task.completed:,.0f}/{task.total:,.0f} s"),
        TimeRemainingColumn(),
        console=console,
        transient=True,
    )


def _navigate_log(log: Path, out: Path, models: list[Path], policy: str, **kw: object) -> None:
    """``navigate --log``: read, align, navigate, write the same outputs as a scenario."""
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rinscal.cli._app import console, fail, flag_text, streaming_process
    from rinscal.errors import RinscalError
    from rinscal.io.tables import is_flight_log

    inputs = [log, *models, *([kw["mapping"]] if kw["mapping"] else []),
              *([kw["track"]] if kw["track"] else [])]  # fmt: skip
    for src in inputs:
        input_file(Path(src))  # type: ignore[arg-type]
    for name in _OUTPUTS:
        for src in inputs:
            if is_same_file(out / name, Path(src)):  # type: ignore[arg-type]
                raise fail(
                    f"{out / name}: refusing to overwrite the input {src}; choose another --out"
                )
    if is_flight_log(log):
        raise fail(f"{log}: a flight log; navigate --log reads CSV, TSV or Parquet recordings")
    prepare_outputs(folders=[("--out", out)])
    streaming_process()  # the recording is read piece by piece, twice
    try:
        from rinscal.io.mapping import read_mapping
        from rinscal.nav.recording import heading_text, navigate_log, parse_site

        ahead = _FiguresAhead(kw["jobs"])  # type: ignore[arg-type]
        mapping = read_mapping(kw["mapping"], "navigation") if kw["mapping"] else None
        site = parse_site(kw["site"]) if kw["site"] is not None else None  # type: ignore[arg-type]
        with _progress() as progress:  # type: ignore[attr-defined]
            task = progress.add_task("reading", total=1.0)

            def tick(done: float, total: float) -> None:
                # first pass: the length is not known yet (the bar shows seconds read)
                stage = "reading" if math.isnan(total) else "navigating"
                known = max(done, 1.0) if math.isnan(total) else total
                progress.update(task, description=stage, completed=done, total=known)
                ahead.start()  # the first piece has been read

            nav = navigate_log(
                log, mapping=mapping, run=kw["run"], models=[str(m) for m in models],
                policy=policy, site=site, heading_deg=kw["heading"], track=kw["track"],
                track_utc_start=kw["track_utc_start"], align_s=kw["align_s"],
                align_start_s=kw["align_start_s"], imu=kw["imu"], allow_gaps=kw["allow_gaps"],
                progress=tick, n_jobs=kw["jobs"], temperatures=ahead.temperatures,
                **kw["aiding"],  # type: ignore[arg-type]
            )  # type: ignore[arg-type]  # fmt: skip
    except RinscalError as exc:
        raise fail(str(exc)) from None
    summary = nav.summary
    _save(nav, out, kw["jobs"], ahead)  # type: ignore[arg-type]
    console.print(nav.report["recording_kind"]["text"], highlight=False, soft_wrap=True)
    console.print(heading_text(nav.report), highlight=False, soft_wrap=True)
    rot = nav.report["rotation"]
    if rot.get("source") == "encoder":
        console.print(
            f"turntable (encoder): positions {rot['positions_deg']} deg, {rot['dwells']} dwells "
            f"of {rot['dwell_s_median']:.0f} s (median), turning at "
            f"{rot['turning_rate_dps_median']:.1f} °/s",
            highlight=False,
            soft_wrap=True,
        )
    gaps = nav.report["gaps"]
    if gaps["count"]:
        console.print(f"{gaps['count']} gap(s) in time, the longest {gaps['longest_s']:.3f} s",
                      highlight=False, soft_wrap=True)  # fmt: skip
    if "aiding" in nav.report:
        console.print(
            f"aiding: {nav.report['aiding']} (σ {nav.report['gnss_sd_m']:g} m per coordinate); "
            + nav.report["aiding_note"],
            highlight=False,
            soft_wrap=True,
        )
    for w in nav.warnings:  # a library's words: its arguments said as flags
        console.print(f"warning: {flag_text(w)}", highlight=False, soft_wrap=True)
    c = nav.result.config
    console.print(
        f"navigation from {c.nav_start_s:.1f} s to {c.time_origin_s + c.duration_s:.1f} s of "
        "the recording's clock",
        highlight=False,
        soft_wrap=True,
    )
    _print_variants(summary)


__all__ = ["navigate"]
