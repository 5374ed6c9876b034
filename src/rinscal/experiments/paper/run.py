"""The reproduction's computation, stage by stage, without printing or writing a report:
the plan (:func:`plan_reproduction`: the sizes, the plant, the number of steps) and the run
(:func:`run_reproduction`: calibration, navigation and, with ``units``, the study).

:func:`rinscal.reproduce` (:mod:`rinscal.report.runs`) runs it and writes the report;
``rinscal reproduce`` calls that.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rinscal import _check
from rinscal.cluster import dask_client, local_workers
from rinscal.errors import ConfigError
from rinscal.experiments.paper.calibration import CalibrationResult, calibration_stage
from rinscal.experiments.paper.config import ReproConfig, load_plant, plant_info
from rinscal.experiments.paper.navigation import (
    NavRunResult,
    alignment_config,
    navigation_jobs,
    navigation_stage,
)
from rinscal.experiments.study.runner import RunSummary, StudyStore, run_study
from rinscal.experiments.study.spec import StudySpec, reproduction_spec
from rinscal.experiments.study.tasks import study_tasks
from rinscal.presets import DEFAULT_PRESET
from rinscal.sim.config import ImuConfig

#: Progress steps of the calibration stage (its ``step`` calls; the bar is filled after it).
CALIBRATION_STEPS = 10
#: The timing keys of ``metrics.json`` (``timings_s``), one per stage.
CALIBRATION_TIMING = "calibration (simulate, fit, select, held-out)"
NAVIGATION_TIMING = "navigation (all runs)"

Progress = Callable[[float, float], None]


@dataclass(frozen=True)
class ReproductionPlan:
    """What a reproduction will run, checked before any work.

    ``config`` the sizes, ``plant`` the IMU, ``info`` its :func:`plant_info`, ``units`` the
    study's units (0: none), ``study`` its spec (``None`` without units), ``steps`` the
    progress total [steps]: calibration, navigation runs, study tasks, report.
    """

    config: ReproConfig
    plant: ImuConfig
    info: dict[str, Any]
    units: int
    study: StudySpec | None
    steps: int

    @property
    def navigation_runs(self) -> int:
        """Navigation runs of the reproduction (not of the study)."""
        return len(navigation_jobs(self.config))


@dataclass(frozen=True)
class ReproductionRun:
    """The computed stages: ``calibration``, ``navigation`` (one result a run), ``study``
    (its summary, ``None`` without units), ``timings`` [s] per stage."""

    plan: ReproductionPlan
    calibration: CalibrationResult
    navigation: list[NavRunResult]
    study: RunSummary | None
    timings: dict[str, float] = field(default_factory=dict)


def plan_reproduction(
    *,
    quick: bool = False,
    seed: int = 0,
    imu: str | os.PathLike[str] = DEFAULT_PRESET,
    align_s: float = 600.0,
    align_start_s: float = 0.0,
    units: int = 0,
    n_jobs: int | None = None,
    workers: int | None = None,
) -> ReproductionPlan:
    """Check the reproduction's settings and size it (cheap: nothing is simulated).

    Parameters are those of :func:`rinscal.reproduce`; ``align_s`` and ``align_start_s`` in
    s, ``n_jobs`` (or ``workers``, its other name) worker processes (default one per core).

    Raises
    ------
    ConfigError
        A bad setting (an unknown IMU, an alignment the plant cannot do, a bad study size).
    """
    _check.flag("quick", quick)
    _check.number("seed", seed, min=0, integer=True)
    _check.path_like("imu", imu)
    _check.number("units", units, min=0, integer=True)
    workers = _check.alias("n_jobs", n_jobs, "workers", workers)
    _check.number("n_jobs" if n_jobs is not None else "workers", workers, min=1, integer=True,
                  optional=True)  # fmt: skip
    make = ReproConfig.quick_preset if quick else ReproConfig.full
    cfg = make(
        seed, local_workers(workers), imu=str(imu), align_s=align_s, align_start_s=align_start_s
    )
    plant = load_plant(cfg.imu)
    spec = reproduction_spec(cfg, units) if units else None  # refuse bad settings early
    alignment_config(plant, cfg.align_s, cfg.align_start_s)
    n_study = sum(1 + len(n) for _, n in study_tasks(spec)) if spec is not None else 0
    steps = CALIBRATION_STEPS + len(navigation_jobs(cfg)) + n_study + 1
    return ReproductionPlan(cfg, plant, plant_info(cfg.imu, plant), units, spec, steps)


def run_reproduction(
    plan: ReproductionPlan,
    study_folder: str | os.PathLike[str] | None = None,
    progress: Progress | None = None,
) -> ReproductionRun:
    """Run the calibration, the navigation and (with units) the study of ``plan``.

    ``study_folder`` holds the study's results (required with units; resumable).
    ``progress(done, total)`` [steps] is called after every step; the last step, the
    report, is its caller's.
    """
    _check.callback("progress", progress)
    cfg, total = plan.config, float(plan.steps)
    done = 0.0

    def tick(step: float = 1.0) -> None:
        nonlocal done
        done += step
        if progress is not None:
            progress(done, total)

    if plan.study is not None and study_folder is None:
        raise ConfigError("study_folder: a reproduction with units needs one")
    timings: dict[str, float] = {}
    # one cluster for every stage (cfg.jobs worker processes, started once); none for one job
    with dask_client(workers=cfg.jobs) if cfg.jobs > 1 else nullcontext() as client:
        t0 = time.perf_counter()
        cal = calibration_stage(
            cfg,
            imu=plan.plant,
            step=lambda _what: tick() if done < CALIBRATION_STEPS else None,
            client=client,
        )
        tick(CALIBRATION_STEPS - done)
        timings[CALIBRATION_TIMING] = time.perf_counter() - t0
        t0 = time.perf_counter()
        nav = navigation_stage(
            cfg, cal.models, done=lambda _r: tick(), imu=plan.plant, extra=cal.extra_models,
            client=client,
        )  # fmt: skip
        timings[NAVIGATION_TIMING] = time.perf_counter() - t0
        run = None
        if plan.study is not None:
            t0 = time.perf_counter()
            start = done

            def study_tick(done_tasks: float, _total: float) -> None:
                tick(start + done_tasks - done)

            store = StudyStore(Path(study_folder))  # type: ignore[arg-type]
            run = run_study(plan.study, store, workers=cfg.jobs, progress=study_tick, client=client)
            timings[f"study ({plan.units} units)"] = time.perf_counter() - t0
    return ReproductionRun(plan, cal, nav, run, timings)


__all__ = [
    "ReproductionPlan",
    "ReproductionRun",
    "plan_reproduction",
    "run_reproduction",
]
