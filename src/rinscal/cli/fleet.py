"""CLI command: ``rinscal fleet fit`` — every unit's log fitted on Dask, checked against limits."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from rinscal.cli._app import app, print_table
from rinscal.cli._options import (
    SchedulerOpt,
    TLSCAOpt,
    TLSCertOpt,
    TLSKeyOpt,
    WorkerJobsOpt,
    WorkersOpt,
    cluster_options,
    prepare_outputs,
)

fleet_app = typer.Typer(
    help="Calibrate a fleet of IMUs: one log per unit, fitted in parallel on Dask.",
    no_args_is_help=True,
    rich_markup_mode=None,
)
app.add_typer(fleet_app, name="fleet")


@fleet_app.command("fit")
def fleet_fit(
    logs: Annotated[
        list[Path],
        typer.Argument(
            help="One calibration log per unit. A unit is named by its file name without the "
            "suffix when those differ (SN0042.csv: SN0042); else by the fewest trailing folder "
            "names that tell the units apart, joined by '+', the file name dropped when all "
            "share it (SN001/imu.csv: SN001; lineA/SN001/imu.csv and lineB/SN001/imu.csv: "
            "lineA+SN001 and lineB+SN001). A log already in OUT keeps its unit's name."
        ),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Results folder; run again to resume.")],
    method: Annotated[
        str, typer.Option("--method", help="Fit method, as rinscal fit (default auto).")
    ] = "auto",
    export: Annotated[
        str, typer.Option("--export", help="Export per unit: c, px4, ardupilot or none.")
    ] = "c",
    limits: Annotated[
        Path | None,
        typer.Option(
            "--limits",
            help="Pass/fail limits (TOML: [limits.gyro], [limits.accel] or [limits.<channel>] "
            "with max_thermal_span, max_heldout_rms, max_noise_density in the log's units).",
        ),
    ] = None,
    jobs: WorkerJobsOpt = None,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
    tls_ca_file: TLSCAOpt = None,
    tls_cert: TLSCertOpt = None,
    tls_key: TLSKeyOpt = None,
    retry_failed: Annotated[
        bool, typer.Option("--retry-failed", help="Fit again the units that failed before.")
    ] = False,
) -> None:
    """Fit every unit's log as its own task on Dask (resumable) and check it against limits.

    Writes into OUT one model file and one export per unit (units/, exports/), the failed
    units with their error (failed/), report.html, and verdicts.csv (pass, fail with the
    reasons, or failed), figures.csv (every unit's figures and coefficients) and
    distribution.csv (their spread across units). Units already fitted from the same log are
    not fitted again.
    """
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
    from rich.table import Table

    from rinscal.calibration.thermal.model import FIT_METHODS
    from rinscal.cli._app import console, fail
    from rinscal.cli._options import worker_jobs
    from rinscal.errors import RinscalError
    from rinscal.production.fleet import (
        EXPORTS,
        FleetLimits,
        FleetStore,
        fleet_report,
        run_fleet,
        split_side_files,
        write_fleet_report,
    )
    from rinscal.report.fleet_report import fleet_html

    if method not in FIT_METHODS:
        raise fail(f"--method must be one of {', '.join(FIT_METHODS)}, got {method!r}")
    if export not in EXPORTS:
        raise fail(f"--export must be one of {', '.join(EXPORTS)}, got {export!r}")
    workers = worker_jobs(jobs, workers)
    tls = cluster_options(workers, scheduler, tls_ca_file, tls_cert, tls_key)
    missing = [str(p) for p in logs if not p.is_file()]
    if missing:
        raise fail(f"log(s) not found: {', '.join(missing)}")
    units, side = split_side_files(logs)
    if not units:
        raise fail(f"no log among the {len(logs)} file(s) given: only side files ({side[0]}, ...)")
    try:
        lim = FleetLimits.from_toml(limits) if limits is not None else FleetLimits()
    except RinscalError as exc:
        raise fail(str(exc)) from None
    prepare_outputs(folders=[("--out", out)])
    if side:
        shown = ", ".join(Path(p).name for p in side[:5]) + (", ..." if len(side) > 5 else "")
        console.print(
            f"skipped {len(side)} side file(s) of the logs given (truth, metadata; not units): "
            f"{shown}",
            highlight=False,
            soft_wrap=True,
        )
    try:
        store = FleetStore(out)
        with Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            TextColumn("{task.completed}/{task.total} units"),
            TimeElapsedColumn(),
            console=console,
            transient=True,
        ) as progress:
            task = progress.add_task("fitting", total=len(units))
            run = run_fleet(
                units,
                store,
                method=method,
                export=export,
                workers=workers,
                scheduler=scheduler,
                tls=tls,
                retry_failed=retry_failed,
                on_unit=lambda unit, status: progress.advance(task),
            )
        report = fleet_report(store, lim)
        page = fleet_html(report, lim.source if limits else "none given", store.options())
        paths = write_fleet_report(store, report, page)
    except RinscalError as exc:
        raise fail(str(exc)) from None
    console.print(
        f"{run.units} unit(s): {run.fitted} fitted, {run.failed} failed, {run.skipped} already "
        f"done or failed before, in {run.elapsed_s:.0f} s on {run.workers} worker(s)",
        highlight=False,
    )
    table = Table(title=f"verdicts ({lim.source if limits is not None else 'no limits given'})")
    table.add_column("unit")
    table.add_column("verdict")
    table.add_column("why")
    for _, r in report.verdicts.iterrows():
        table.add_row(str(r["unit"]), str(r["verdict"]), str(r["why"]))
    print_table(console, table)
    console.print(f"wrote {', '.join(str(p) for p in paths.values())}", highlight=False)
