"""CLI command: ``rinscal reproduce`` — the paper's Section 5 end to end, one report."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table
from rich.text import Text

from rinscal.cli._app import app, print_table
from rinscal.cli._options import (
    AlignLengthOpt,
    AlignStartOpt,
    ImuOpt,
    WorkerJobsOpt,
    WorkersOpt,
)
from rinscal.cli._timings import format_duration, timing, timing_phrase
from rinscal.presets import DEFAULT_PRESET


def expected_time(quick: bool) -> str:
    """The console's line on how long this reproduction takes, from the package's measured
    timings (:mod:`rinscal.cli._timings`, written by ``docs/scripts/timings.py``)."""
    name = "quick_reproduction" if quick else "full_reproduction"
    t = timing(name)
    if t is None:
        return "its wall time is not measured yet (python docs/scripts/timings.py --write --full)"
    return (
        f"expect about {format_duration(t.wall_s)} (measured on {t.cores} cores, load "
        f"{max(t.load, default=float('nan')):.1f}, {t.measured[:10]})"
    )


def _print_headline(console: Any, rows: list[dict[str, Any]]) -> None:
    """The headline: max position error per method over the lab and vehicle runs [nmi]."""
    table = Table(title="max position error over the lab and vehicle runs [nmi]")
    for name in ("method", "runs", "mean", "sd", "min", "max"):
        table.add_column(name, justify="left" if name == "method" else "right")
    for r in rows:
        if r.get("runs") != "lab + vehicle":
            continue
        table.add_row(
            str(r["method"]),
            str(r["n runs"]),
            *(f"{r[f'max error {k} [nmi]']:.3f}" for k in ("mean", "sd", "min", "max")),
        )
    if table.row_count:
        print_table(console, table)


@app.command("reproduce")
def reproduce(
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder for report.html, PNG, CSV.")],
    quick: Annotated[
        bool,
        typer.Option(
            "--quick",
            help="Shorter runs, lower rates: "
            + timing_phrase("quick_reproduction")
            + " (docs/scripts/timings.py measures it; the first run after an install "
            "also compiles numba's kernels into its cache).",
        ),
    ] = False,
    jobs: WorkerJobsOpt = None,
    workers: WorkersOpt = None,
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seed of every random number.")] = 0,
    imu: ImuOpt = DEFAULT_PRESET,
    align_s: AlignLengthOpt = 600.0,
    align_start_s: AlignStartOpt = 0.0,
    units: Annotated[
        int,
        typer.Option(
            "--units",
            "-n",
            min=0,
            max=100000,
            help="Also run the navigation part as a study over N units (OUT/study, on Dask "
            "with --jobs; resumable): the claims with 95 % intervals.",
        ),
    ] = 0,
) -> None:
    """Re-run every experiment of the paper's Section 5 on one simulated plant (--imu).

    Writes OUT/report.html (self-contained), OUT/figures/*.png, OUT/tables/*.csv,
    OUT/models/*.json (the fitted models) and OUT/metrics.json; with --units N also
    OUT/study (the study's folder and report).

    The report and metrics.json name the plant that ran.
    """

    # deferred: loaded when the command runs, so that `rinscal --help` starts fast
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from rinscal.cli._app import console, fail, styled
    from rinscal.cli._options import prepare_outputs, worker_jobs
    from rinscal.errors import RinscalError
    from rinscal.experiments.paper.claims import PAPER_PAIRS
    from rinscal.experiments.paper.run import plan_reproduction
    from rinscal.report.runs import reproduce as run_and_report
    from rinscal.report.verdict_view import claims_lines

    options = {
        "quick": quick, "seed": seed, "imu": imu, "align_s": align_s,
        "align_start_s": align_start_s, "units": units, "n_jobs": worker_jobs(jobs, workers),
    }  # fmt: skip
    try:
        plan = plan_reproduction(**options)
    except RinscalError as exc:
        raise fail(str(exc)) from None
    prepare_outputs(folders=[("--out", out)])
    info = plan.info
    console.print(
        f"plant: {info['name']} ({info['kind']} {info['spec']}); other presets: "
        + (", ".join(info["run_other"]) or "none"),
        highlight=False,
    )
    if quick:
        console.print(f"quick reproduction, seed {seed}: {expected_time(True)}", highlight=False)
    else:
        console.print(
            f"full reproduction, seed {seed}, {plan.config.jobs} worker(s) (--jobs): "
            f"{expected_time(False)}; --quick: {timing_phrase('quick_reproduction')}",
            highlight=False,
        )
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed:.0f}/{task.total:.0f} steps"),
        TimeElapsedColumn(),
    )
    try:
        with Progress(*columns, console=console) as progress:
            bar = progress.add_task("reproduction", total=plan.steps)

            def show(done: float, total: float) -> None:
                progress.update(bar, completed=done, total=total)

            result = run_and_report(out, **options, progress=show)  # type: ignore[arg-type]
    except RinscalError as exc:
        raise fail(str(exc)) from None
    metrics, written, checked = result.metrics, result.written, result.claims
    total = metrics["timings_s"]["total"]
    study_lines = result.study.verdicts if result.study is not None else []
    console.print(f"wrote {out / 'report.html'} in {total:.0f} s", highlight=False)
    _print_headline(console, metrics.get("nav_by_method", []))
    cl = written.tables["claims"]
    paper = [(m, r) in PAPER_PAIRS for m, r in zip(cl["method"], cl["reference"], strict=True)]
    shown = cl[paper | (cl["group"] == "lab + vehicle").to_numpy()]
    console.print(
        "the claims, paired run by run (method − reference [nmi], 95 % Student-t interval; "
        f"holds only when it lies below zero; all {len(cl)} in {out / 'claims.csv'}):",
        highlight=False,
    )
    for line in claims_lines(shown):
        console.print(f"  {line}", highlight=False)
    verdicts = Table(title="the paper's claims on held-out residuals [µg]")
    verdicts.add_column("verdict")
    verdicts.add_column("claim")
    for c in checked.values():
        mark = styled("holds", "green") if c["holds"] else styled("does not hold", "red")
        tag = "asserted" if c["asserted"] else "reported"
        verdicts.add_row(mark + Text(f" ({tag})"), c["what"])
    print_table(console, verdicts)
    if units:
        console.print(
            f"over {units} units (report: {out / 'study' / 'report.html'}):",
            highlight=False,
        )
        for line in study_lines:
            console.print(f"  {line}", highlight=False)
