"""CLI command: ``rinscal reproduce`` — the paper's Section 5 end to end, one report."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table
from rich.text import Text

from rinscal.cli._app import app, print_table
from rinscal.cli._options import AlignLengthOpt, AlignStartOpt, ImuOpt, WorkersOpt
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
    workers: WorkersOpt = None,
    jobs: Annotated[
        int | None,
        typer.Option("--jobs", "-j", min=1, max=1024, hidden=True, help="Old name of --workers."),
    ] = None,
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
            "with --workers; resumable): the claims with 95 % intervals.",
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

    from rinscal.cli._app import console, err_console, fail, styled
    from rinscal.cli._options import prepare_outputs
    from rinscal.cluster import local_workers
    from rinscal.errors import RinscalError
    from rinscal.experiments.paper.calibration import calibration_stage
    from rinscal.experiments.paper.claims import PAPER_PAIRS, claims
    from rinscal.experiments.paper.config import ReproConfig, load_plant, plant_info
    from rinscal.experiments.paper.navigation import (
        alignment_config,
        navigation_jobs,
        navigation_stage,
    )
    from rinscal.experiments.study.runner import StudyStore, run_study
    from rinscal.experiments.study.spec import reproduction_spec
    from rinscal.experiments.study.tasks import study_tasks
    from rinscal.io.atomic import write_atomic
    from rinscal.report.paper_report import write_reproduction
    from rinscal.report.study_report import write_study_report
    from rinscal.report.verdict_view import claims_lines

    if jobs is not None:
        if workers is not None:
            raise fail("--jobs is the old name of --workers: give one of them")
        err_console.print(styled("note:", "cyan", " --jobs is now --workers (-w)"))
        workers = jobs
    jobs = local_workers(workers)  # navigation runs in parallel
    try:
        options = {"imu": imu, "align_s": align_s, "align_start_s": align_start_s}
        make = ReproConfig.quick_preset if quick else ReproConfig.full
        cfg = make(seed, jobs, **options)
        plant = load_plant(cfg.imu)
        if units:
            reproduction_spec(cfg, units)  # refuse bad settings before any work
        alignment_config(plant, cfg.align_s, cfg.align_start_s)
    except RinscalError as exc:
        raise fail(str(exc)) from None
    prepare_outputs(folders=[("--out", out)])
    info = plant_info(cfg.imu, plant)
    n_nav = len(navigation_jobs(cfg))
    console.print(
        f"plant: {info['name']} ({info['kind']} {info['spec']}); other presets: "
        + (", ".join(info["run_other"]) or "none"),
        highlight=False,
    )
    if quick:
        console.print(f"quick reproduction, seed {seed}: {expected_time(True)}", highlight=False)
    else:
        console.print(
            f"full reproduction, seed {seed}, {jobs} worker(s): {expected_time(False)}; "
            f"--quick: {timing_phrase('quick_reproduction')}",
            highlight=False,
        )
    timings: dict[str, float] = {}
    t_all = time.perf_counter()
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.fields[what]}"),
        TimeElapsedColumn(),
    )
    try:
        with Progress(*columns, console=console) as progress:
            t0 = time.perf_counter()
            cal_task = progress.add_task("calibration", total=10, what="")

            def cal_step(what: str) -> None:
                progress.update(cal_task, advance=1, what=what)

            cal = calibration_stage(cfg, imu=plant, step=cal_step)
            progress.update(cal_task, completed=10, what="done")
            timings["calibration (simulate, fit, select, held-out)"] = time.perf_counter() - t0

            t0 = time.perf_counter()
            nav_task = progress.add_task("navigation", total=n_nav, what="")

            def nav_done(r: object) -> None:
                job = r.job  # type: ignore[attr-defined]
                progress.update(nav_task, advance=1, what=f"{job.scenario} {job.index}")

            nav = navigation_stage(
                cfg, cal.models, done=nav_done, imu=plant, extra=cal.extra_models
            )
            timings["navigation (all runs)"] = time.perf_counter() - t0

            study_tables, study_lines = None, []
            if units:
                t0 = time.perf_counter()
                spec = reproduction_spec(cfg, units)
                n_tasks = sum(1 + len(n) for _, n in study_tasks(spec))
                st_task = progress.add_task(f"study ({units} units)", total=n_tasks, what="")

                def st_done(p: object) -> None:
                    progress.update(
                        st_task,
                        completed=p.done + p.failed,  # type: ignore[attr-defined]
                        what=f"{p.failed} failed" if p.failed else "",  # type: ignore[attr-defined]
                    )

                store = StudyStore(out / "study")
                run = run_study(spec, store, workers=jobs, on_progress=st_done)
                st = write_study_report(store, spec, run)
                study_tables, study_lines = st.tables, st.verdicts
                timings[f"study ({units} units)"] = time.perf_counter() - t0

            t0 = time.perf_counter()
            rep_task = progress.add_task("report", total=1, what="figures, tables, html")
            written = write_reproduction(
                out, cfg, cal, nav, timings, plant=info, study=study_tables
            )
            progress.update(rep_task, advance=1, what="done")
    except RinscalError as exc:
        raise fail(str(exc)) from None
    timings["report"] = time.perf_counter() - t0
    total = time.perf_counter() - t_all
    checked = claims(cal)
    metrics = json.loads(written.metrics_path.read_text())
    metrics["timings_s"] = {**timings, "total": total}
    text = json.dumps(metrics, indent=2, allow_nan=True) + "\n"
    write_atomic(written.metrics_path, lambda tmp: tmp.write_text(text))
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
