"""The two whole experiments as one function each, computed and written to a folder:
:func:`study` (``rinscal study``) and :func:`reproduce` (``rinscal reproduce``).

They sit with the report writers, which the computation (:mod:`rinscal.experiments`) does not
import; neither prints: the commands print what they return.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rinscal import _check
from rinscal.cluster import TLSFiles
from rinscal.experiments.paper.claims import claims
from rinscal.experiments.paper.run import (
    ReproductionRun,
    plan_reproduction,
    run_reproduction,
)
from rinscal.experiments.study.runner import RunSummary, StudyStore, run_study
from rinscal.experiments.study.spec import StudySpec, load_spec
from rinscal.io.atomic import write_atomic
from rinscal.presets import DEFAULT_PRESET
from rinscal.report.paper_report import Written, write_reproduction
from rinscal.report.study_report import WrittenStudy, write_study_report

Progress = Callable[[float, float], None]


@dataclass(frozen=True)
class Study:
    """What :func:`study` ran and wrote: ``spec``, ``run`` (tasks computed, skipped, failed,
    wall time [s]) and ``written`` (``report`` path, ``tables``, ``verdicts`` in words)."""

    spec: StudySpec
    run: RunSummary
    written: WrittenStudy


@dataclass(frozen=True)
class Reproduction:
    """What :func:`reproduce` ran and wrote: ``run`` (the computed stages, its ``plan``),
    ``written`` (the report's paths and tables), ``metrics`` (``metrics.json``, with
    ``timings_s`` [s]), ``claims`` (the paper's claims in µg, checked) and ``study``
    (the study's report, ``None`` without units)."""

    run: ReproductionRun
    written: Written
    metrics: dict[str, Any]
    claims: dict[str, Any]
    study: WrittenStudy | None


def study(
    spec: str | os.PathLike[str] | StudySpec,
    out: str | os.PathLike[str],
    *,
    units: int | None = None,
    quick: bool = False,
    imu: str | Sequence[str] | None = None,
    n_jobs: int | None = None,
    scheduler: str | None = None,
    tls: TLSFiles | None = None,
    retry_failed: bool = False,
    progress: Progress | None = None,
    workers: int | None = None,
) -> Study:
    """Run a Monte Carlo study into ``out`` and write its report (resumable).

    Parameters
    ----------
    spec : str, path-like or StudySpec
        A built-in study (``paper``, ``sensitivity``), a study TOML file or a spec.
    out : path-like
        Results folder (created); run again with it to resume.
    units : int, optional
        Number of units (default: the spec's).
    quick : bool
        The spec's ``[quick]`` sizes.
    imu : str or sequence of str, optional
        Replace the spec's plants with these presets or IMU TOML files (default: the spec's;
        the built-in studies' default plant is ``"paper"``).
    n_jobs : int, optional
        Cores: local worker processes, one each (default every core); ignored with
        ``scheduler``. ``workers=`` is its other name (still taken).
    scheduler : str, optional
        Address of a Dask scheduler to run on.
    tls : TLSFiles, optional
        Certificates for a ``tls://`` scheduler.
    retry_failed : bool
        Run again the tasks that failed earlier.
    progress : callable, optional
        ``progress(done, total)`` [tasks] after every finished task.

    Returns
    -------
    Study

    Raises
    ------
    ConfigError
        An unknown or invalid spec, bad sizes.
    """
    _check.path_like("out", out)
    _check.number("units", units, min=1, integer=True, optional=True)
    _check.flag("quick", quick)
    workers = _check.alias("n_jobs", n_jobs, "workers", workers)
    _check.number("n_jobs" if n_jobs is not None else "workers", workers, min=1, integer=True,
                  optional=True)  # fmt: skip
    _check.flag("retry_failed", retry_failed)
    _check.callback("progress", progress)
    if not isinstance(spec, StudySpec):
        _check.path_like("spec", spec)
        spec = load_spec(spec, quick=quick, units_override=units, imu_override=imu)
    store = StudyStore(Path(out))
    run = run_study(
        spec,
        store,
        workers=workers,
        scheduler=scheduler,
        tls=tls,
        retry_failed=retry_failed,
        progress=progress,
    )
    return Study(spec, run, write_study_report(store, spec, run))


def reproduce(
    out: str | os.PathLike[str],
    *,
    quick: bool = False,
    seed: int = 0,
    imu: str | os.PathLike[str] = DEFAULT_PRESET,
    align_s: float = 600.0,
    align_start_s: float = 0.0,
    units: int = 0,
    n_jobs: int | None = None,
    progress: Progress | None = None,
    workers: int | None = None,
) -> Reproduction:
    """Re-run every experiment of the paper's Section 5 on one simulated plant into ``out``.

    Writes ``out/report.html``, ``figures/*.png``, ``tables/*.csv``, ``models/*.json`` and
    ``metrics.json``; with ``units`` also ``out/study``.

    Parameters
    ----------
    out : path-like
        The report's folder (created).
    quick : bool
        Shorter runs at lower rates (the same experiments).
    seed : int
        Seed of every random number.
    imu : str or path-like
        The plant: a preset name or an IMU TOML file (the report names it); default
        ``"paper"``.
    align_s : float [s]
        Self-alignment time of the cold starts.
    align_start_s : float [s]
        Start of the alignment after power-on.
    units : int
        Also run the navigation part as a study over this many units (0: none).
    n_jobs : int, optional
        Cores (default every core): the calibration's tasks and the navigation runs on as
        many local worker processes; 1: all in this process. ``workers=`` is its other name
        (still taken). The results are the same whatever the number.
    progress : callable, optional
        ``progress(done, total)`` [steps]: calibration, navigation runs, study tasks, report.

    Returns
    -------
    Reproduction

    Raises
    ------
    ConfigError
        A bad setting, before any work.
    """
    _check.path_like("out", out)
    _check.callback("progress", progress)
    plan = plan_reproduction(
        quick=quick, seed=seed, imu=imu, align_s=align_s, align_start_s=align_start_s,
        units=units, n_jobs=n_jobs, workers=workers,
    )  # fmt: skip
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t_all = time.perf_counter()
    run = run_reproduction(plan, out / "study", progress)
    timings = dict(run.timings)
    st = None
    if run.study is not None and plan.study is not None:
        st = write_study_report(StudyStore(out / "study"), plan.study, run.study)
    t0 = time.perf_counter()
    written = write_reproduction(
        out, plan.config, run.calibration, run.navigation, timings, plant=plan.info,
        study=None if st is None else st.tables,
    )  # fmt: skip
    if progress is not None:
        progress(float(plan.steps), float(plan.steps))
    timings["report"] = time.perf_counter() - t0
    metrics = json.loads(written.metrics_path.read_text())
    metrics["timings_s"] = {**timings, "total": time.perf_counter() - t_all}
    text = json.dumps(metrics, indent=2, allow_nan=True) + "\n"
    write_atomic(written.metrics_path, lambda tmp: tmp.write_text(text))
    return Reproduction(run, written, metrics, claims(run.calibration), st)


__all__ = ["Reproduction", "Study", "reproduce", "study"]
