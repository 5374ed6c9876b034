"""CLI command: ``rinscal study`` — a Monte Carlo study on Dask, resumable, one report."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from rinscal.cli._app import app
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
from rinscal.cli._timings import timing_phrase
from rinscal.presets import PRESETS


@app.command("study")
def study(
    spec: Annotated[
        str,
        typer.Argument(
            metavar="SPEC",
            help="A built-in study (paper, sensitivity, field) or a study TOML file.",
        ),
    ],
    out: Annotated[
        Path,
        typer.Option("--out", "-o", help="Results folder; run again with it to resume."),
    ],
    units: Annotated[
        int | None,
        typer.Option(
            "--units",
            "-n",
            min=1,
            max=100000,
            help="Number of units, 1-100000 (default: the spec's).",
        ),
    ] = None,
    quick: Annotated[
        bool,
        typer.Option(
            "--quick",
            help="The spec's [quick] sizes: lower rates, shorter runs ("
            + timing_phrase("quick_study", sized=True)
            + "; docs/scripts/timings.py measures it; the wall time grows with units × "
            "plants / --jobs).",
        ),
    ] = False,
    jobs: WorkerJobsOpt = None,
    workers: WorkersOpt = None,
    scheduler: SchedulerOpt = None,
    tls_ca_file: TLSCAOpt = None,
    tls_cert: TLSCertOpt = None,
    tls_key: TLSKeyOpt = None,
    imu: Annotated[
        list[str] | None,
        typer.Option(
            "--imu",
            help=f"Replace the spec's plants with this preset ({', '.join(PRESETS)}) or IMU "
            "TOML file, the spec's sweep kept; give it more than once to run the study over "
            "several plants (e.g. --imu navigation_grade --imu navigation_grade_mechanistic: "
            "both thermal laws).",
        ),
    ] = None,
    retry_failed: Annotated[
        bool, typer.Option("--retry-failed", help="Run again the tasks that failed earlier.")
    ] = False,
) -> None:
    """Run a Monte Carlo study: many units, each calibrated on its own soak runs, many cold
    starts, every method on the same raw data; statistics with 95 % confidence intervals.

    Results stream into OUT as tasks finish (OUT/results is a partitioned Parquet dataset);
    an interrupted study resumes with the same command and computes only what is missing.
    Writes OUT/report.html, OUT/tables/*.csv and OUT/summary.json at the end.
    """
    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from rinscal.cli._app import console, fail, styled
    from rinscal.cli._options import worker_jobs
    from rinscal.errors import RinscalError
    from rinscal.experiments.study.spec import load_spec
    from rinscal.experiments.study.tasks import study_tasks
    from rinscal.report.runs import study as run_and_report

    workers = worker_jobs(jobs, workers)
    tls = cluster_options(workers, scheduler, tls_ca_file, tls_cert, tls_key)
    try:
        s = load_spec(spec, quick=quick, units_override=units, imu_override=imu)
    except RinscalError as exc:
        raise fail(str(exc)) from None
    n_tasks = sum(1 + len(n) for _, n in study_tasks(s))
    where = f"cluster {scheduler}" if scheduler else f"{workers or 'one per core'} local worker(s)"
    console.print(
        f"study {s.name}{' (quick)' if quick else ''}: {s.units} unit(s) × {len(s.plants)} "
        f"plant(s) × {sum(len(sc.ambient_c) for sc in s.scenarios)} cold start(s); "
        f"{n_tasks} tasks on {where}",
        highlight=False,
    )
    prepare_outputs(folders=[("--out", out)])
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[left]} left"),
        TimeElapsedColumn(),
        TextColumn("eta"),
        TimeRemainingColumn(),
    )
    try:
        with Progress(*columns, console=console) as progress:
            bar = progress.add_task("tasks", total=n_tasks, left=n_tasks)

            def show(done: float, total: float) -> None:
                progress.update(bar, completed=done, total=total, left=int(total - done))

            result = run_and_report(
                s,
                out,
                n_jobs=workers,
                scheduler=scheduler,
                tls=tls,
                retry_failed=retry_failed,
                progress=show,
            )
        run, written = result.run, result.written
        if run.skipped:
            console.print(
                f"resumed: {run.skipped} task(s) had finished in an earlier run and were not "
                "computed again",
                highlight=False,
            )
        console.print(
            f"computed {run.computed} task(s) in {run.wall_s:.0f} s on {run.workers} worker(s)"
            + (f"; peak memory of a worker {run.peak_mb:.0f} MiB" if run.computed else ""),
            highlight=False,
        )
        if run.failed:
            console.print(
                styled(
                    f"{run.failed} task(s) failed",
                    "red",
                    f": their errors are in {out / 'failed'}; run again with --retry-failed "
                    "to retry them",
                ),
                highlight=False,
            )
    except RinscalError as exc:
        raise fail(str(exc)) from None
    except KeyboardInterrupt:
        console.print(
            f"interrupted: what finished is kept in {out}; run the same command to resume",
            highlight=False,
        )
        raise typer.Exit(130) from None
    console.print(f"wrote {written.report}", highlight=False)
    for line in written.verdicts:
        console.print(f"  {line}", highlight=False)
