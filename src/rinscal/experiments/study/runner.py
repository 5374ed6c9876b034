"""Running a study on Dask distributed, and the results folder it streams into.

This is the I/O edge of :mod:`rinscal.experiments.study`: tasks run on a Dask cluster (a
:class:`distributed.LocalCluster` of worker processes, one per core, started and closed here;
or an existing cluster given by its scheduler address) and the client writes each result as
it arrives. The folder is the study's memory, so that an interrupted study (Ctrl-C, a
killed worker, a killed client) resumes with the same command and computes only what is
missing:

``study.json``
    The resolved spec and its fingerprint; a folder never mixes two studies.
``models/p<plant>/u<unit>.json``
    Each unit's fitted models (JSON text of the model files), its fit warnings and run time.
``results/plant=p<plant>/<task key>.parquet``
    A partitioned Parquet dataset, one file per navigation task, one row per variant
    (:data:`rinscal.experiments.study.tasks.RESULT_COLUMNS`).
``failed/<task key>.json``
    A task that raised: its error and traceback. The study goes on without it; it is
    retried only with ``retry_failed``.

Every file is written atomically (a temporary file moved into place), so a kill leaves
either the whole file or none.
"""

from __future__ import annotations

import json
import os
import resource
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd
from threadpoolctl import threadpool_limits

from rinscal import _check
from rinscal._version import __version__
from rinscal.cluster import TLSFiles, dask_client
from rinscal.errors import ConfigError, RinscalError
from rinscal.experiments.study.spec import StudySpec
from rinscal.experiments.study.tasks import (
    RESULT_COLUMNS,
    CalTask,
    NavTask,
    calibrate_unit,
    navigate_unit,
    plant_config,
    study_tasks,
)
from rinscal.io.atomic import write_atomic


class StudyFolderError(RinscalError):
    """The results folder cannot hold this study (another study's folder, not a folder)."""


# --------------------------------------------------------------------------- the folder
class StudyStore:
    """The results folder of one study (see the module docstring for its layout)."""

    def __init__(self, root: str | os.PathLike[str]) -> None:
        self.root = Path(root)

    # paths
    def model_path(self, t: CalTask) -> Path:
        return self.root / "models" / f"p{t.plant:03d}" / f"u{t.unit:05d}.json"

    def result_path(self, t: NavTask) -> Path:
        return self.root / "results" / f"plant=p{t.plant:03d}" / f"{t.key}.parquet"

    def failure_path(self, key: str) -> Path:
        return self.root / "failed" / f"{key}.json"

    def open(self, spec: StudySpec) -> bool:
        """Create the folder for ``spec``, or check that it already holds the same study.

        Returns
        -------
        bool
            True when the folder already held this study (a resume).

        Raises
        ------
        StudyFolderError
            When the path is a file, or a folder holding another study or other files.
        """
        if self.root.exists() and not self.root.is_dir():
            raise StudyFolderError(f"{self.root}: exists and is not a folder")
        meta_path = self.root / "study.json"
        if meta_path.is_file():
            try:
                old = json.loads(meta_path.read_text())
            except (OSError, json.JSONDecodeError) as e:
                raise StudyFolderError(f"{meta_path}: unreadable ({e})") from None
            if old.get("fingerprint") != spec.fingerprint():
                raise StudyFolderError(
                    f"{self.root}: holds study {old.get('spec', {}).get('name')!r} with other "
                    f"settings (fingerprint {old.get('fingerprint')} ≠ {spec.fingerprint()}: "
                    "another spec, seed, plant or --quick); use another --out"
                )
            meta = dict(old, spec=spec.to_dict(), updated_with=__version__)
            self._write_json(meta_path, meta)
            return True
        if self.root.is_dir() and any(self.root.iterdir()):
            raise StudyFolderError(
                f"{self.root}: is not empty and holds no study.json; use a new or empty folder"
            )
        self.root.mkdir(parents=True, exist_ok=True)
        meta = {"fingerprint": spec.fingerprint(), "rinscal": __version__, "spec": spec.to_dict()}
        self._write_json(meta_path, meta)
        return False

    @staticmethod
    def _write_json(path: Path, obj: Any) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        text = json.dumps(obj, indent=1, allow_nan=True) + "\n"
        write_atomic(path, lambda tmp: tmp.write_text(text))

    def load_models(self, t: CalTask) -> dict[str, Any] | None:
        p = self.model_path(t)
        if not p.is_file():
            return None
        try:
            return json.loads(p.read_text())
        except (OSError, json.JSONDecodeError):
            return None  # a damaged file is recomputed

    def write_models(self, t: CalTask, result: dict[str, Any]) -> None:
        self._write_json(self.model_path(t), result)

    def has_result(self, t: NavTask) -> bool:
        return self.result_path(t).is_file()

    def write_result(self, t: NavTask, df: pd.DataFrame) -> None:
        p = self.result_path(t)
        p.parent.mkdir(parents=True, exist_ok=True)
        # the partition column lives in the folder name, not in the file
        write_atomic(p, lambda tmp: df.drop(columns="plant").to_parquet(tmp, index=False))
        self.failure_path(t.key).unlink(missing_ok=True)

    def has_failure(self, key: str) -> bool:
        return self.failure_path(key).is_file()

    def write_failure(self, key: str, error: str, tb: str) -> None:
        self._write_json(self.failure_path(key), {"task": key, "error": error, "traceback": tb})

    def failures(self) -> pd.DataFrame:
        """Every recorded failure: ``task``, ``error``."""
        rows = []
        d = self.root / "failed"
        for p in sorted(d.glob("*.json")) if d.is_dir() else []:
            try:
                rec = json.loads(p.read_text())
            except (OSError, json.JSONDecodeError):
                rec = {"task": p.stem, "error": "(unreadable failure record)"}
            rows.append({"task": rec.get("task", p.stem), "error": rec.get("error", "")})
        return pd.DataFrame(rows, columns=["task", "error"])

    def read_results(self, spec: StudySpec) -> pd.DataFrame:
        """The results of ``spec``'s navigation tasks that have finished (rows of units
        beyond ``spec.units``, from an earlier larger run, are left out), in task order."""
        files = [
            (t, self.result_path(t))
            for _, navs in study_tasks(spec)
            for t in navs
            if self.result_path(t).is_file()
        ]
        if not files:
            return pd.DataFrame(columns=list(RESULT_COLUMNS))
        frames = []
        for t, p in sorted(files, key=lambda f: (f[0].plant, f[0].unit, f[0].scenario, f[0].start)):
            df = pd.read_parquet(p)
            df.insert(0, "plant", t.plant)
            frames.append(df)
        # reindex: a folder written before a column existed reads it as NaN
        return pd.concat(frames, ignore_index=True).reindex(columns=list(RESULT_COLUMNS))


# --------------------------------------------------------------------------- tasks on workers
def _peak_mb() -> float:
    """Peak resident memory of this (worker) process [MiB]."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


# Tasks run with one BLAS/OpenMP thread whatever the worker's environment: results must not
# depend on the deployment (a multithreaded BLAS sums in another order), and a worker process
# is one core's worth of work.
def _cal_task(spec: StudySpec, plant: Any, task: CalTask) -> dict[str, Any]:
    with threadpool_limits(limits=1):
        out = calibrate_unit(spec, plant, task)
    out["peak_mb"] = _peak_mb()
    return out


def _nav_task(spec: StudySpec, plant: Any, task: NavTask, cal: dict[str, Any]) -> pd.DataFrame:
    with threadpool_limits(limits=1):
        df = navigate_unit(spec, plant, task, cal)
    df["peak_mb"] = _peak_mb()
    return df


def _worker_version() -> str:
    # runs on a worker: this module's global is the worker's installed version
    return __version__


# --------------------------------------------------------------------------- running
@dataclass
class Progress:
    """Counts a progress display needs (navigation and calibration tasks together)."""

    total: int = 0
    done: int = 0
    failed: int = 0
    skipped: int = 0  # finished in an earlier run of the same study

    @property
    def remaining(self) -> int:
        return self.total - self.done - self.failed


@dataclass
class RunSummary:
    """What one run of :func:`run_study` did."""

    resumed: bool
    tasks: int
    computed: int
    failed: int
    skipped: int
    workers: int
    scheduler: str
    wall_s: float
    task_seconds: dict[str, list[float]] = field(default_factory=dict)
    peak_mb: float = float("nan")


def _submit_all(
    client: Any,
    spec: StudySpec,
    variants: dict[int, Any],
    todo: list[tuple[CalTask, dict[str, Any] | None, list[NavTask]]],
    store: StudyStore,
    summary: RunSummary,
    prog: Progress,
    on_progress: Callable[[Progress], None] | None,
) -> float:
    """Submit ``todo`` to ``client`` and write each result as it completes; returns the
    largest peak memory a worker reported [MiB]."""
    from distributed import as_completed  # deferred: Dask is heavy

    peak = 0.0
    versions = client.run(_worker_version)
    wrong = {w: v for w, v in versions.items() if v != __version__}
    if wrong:
        raise ConfigError(
            f"workers run rinscal {sorted(set(wrong.values()))}, this client {__version__}: "
            "install the same version on every worker"
        )
    summary.workers = len(versions)
    spec_f = client.scatter(spec, broadcast=True, hash=False)
    plant_f = {i: client.scatter(v, broadcast=True, hash=False) for i, v in variants.items()}
    what: dict[str, CalTask | NavTask] = {}
    futures = []
    for cal, models, navs in todo:
        if models is None:
            cal_f = client.submit(_cal_task, spec_f, plant_f[cal.plant], cal, key=cal.key)
            what[cal.key] = cal
            futures.append(cal_f)
            dep: Any = cal_f
        else:
            dep = models
        for t in navs:
            f = client.submit(_nav_task, spec_f, plant_f[t.plant], t, dep, key=t.key)
            what[t.key] = t
            futures.append(f)
    del dep
    failed_cals: set[str] = set()
    for fut in as_completed(futures):
        task = what.pop(fut.key)
        if fut.status == "finished":
            result = fut.result()
            if isinstance(task, CalTask):
                store.write_models(task, result)
                summary.task_seconds["calibration"].append(result["elapsed_s"])
            else:
                store.write_result(task, result)
                summary.task_seconds["navigation"].append(float(result["elapsed_s"].iloc[0]))
            peak = max(
                peak,
                float(result["peak_mb"] if isinstance(result, dict) else result["peak_mb"].iloc[0]),
            )
            summary.computed += 1
            prog.done += 1
        else:
            exc = fut.exception()
            msg = f"{type(exc).__name__}: {exc}"
            if isinstance(task, CalTask):
                failed_cals.add(task.key)
            elif task.cal.key in failed_cals:
                msg = f"calibration {task.cal.key} failed: {msg}"
            store.write_failure(task.key, msg, "".join(traceback.format_tb(fut.traceback())))
            summary.failed += 1
            prog.failed += 1
        fut.release()
        if on_progress:
            on_progress(prog)
    return peak


def run_study(
    spec: StudySpec,
    store: StudyStore,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    tls: TLSFiles | None = None,
    retry_failed: bool = False,
    progress: Callable[[float, float], None] | None = None,
    client: Any = None,
    on_progress: Callable[[Progress], None] | None = None,
) -> RunSummary:
    """Run every task of ``spec`` not yet in ``store`` on Dask, writing results as they come.

    Parameters
    ----------
    spec : StudySpec
        The study.
    store : StudyStore
        Its results folder (opened here; see :meth:`StudyStore.open`).
    workers : int, optional
        Worker processes of the local cluster (default: one per core); ignored with
        ``scheduler``.
    scheduler : str, optional
        Address of an existing Dask scheduler to run on instead.
    tls : TLSFiles, optional
        Certificate files for a ``tls://`` scheduler (else Dask's configuration).
    retry_failed : bool
        Run again the tasks that failed in an earlier run (default: keep their record).
    progress : callable, optional
        ``progress(done, total)`` [tasks] after every finished task (the failed counted done).
    client : distributed.Client, optional
        Run on this client (left open) instead of one made from ``workers``/``scheduler``.
    on_progress : callable, optional
        Deprecated (the next release removes it): called with a :class:`Progress` (done,
        failed, skipped, remaining) after every finished task.
    """
    _check.callback("progress", progress)
    _check.callback("on_progress", _check.deprecated("on_progress", on_progress, "progress="))
    shown = on_progress

    def on_progress(p: Progress) -> None:
        if shown is not None:
            shown(p)
        if progress is not None:
            progress(float(p.done + p.failed), float(p.total))

    t0 = time.perf_counter()
    resumed = store.open(spec)
    variants = {i: plant_config(p) for i, p in enumerate(spec.plants)}
    todo: list[tuple[CalTask, dict[str, Any] | None, list[NavTask]]] = []
    prog = Progress()
    for cal, navs in study_tasks(spec):
        prog.total += 1 + len(navs)
        missing = []
        for t in navs:
            if store.has_result(t):
                prog.skipped += 1
            elif store.has_failure(t.key) and not retry_failed:
                prog.failed += 1
            else:
                missing.append(t)
        models = store.load_models(cal)
        if models is not None or not missing:
            prog.skipped += 1  # fitted earlier, or nothing left that needs its models
        elif store.has_failure(cal.key) and not retry_failed:
            prog.failed += 1 + len(missing)
            missing = []
        if missing:
            todo.append((cal, models, missing))
    prog.done = prog.skipped
    summary = RunSummary(resumed, prog.total, 0, 0, prog.skipped, 0, scheduler or "local", 0.0)
    summary.task_seconds = {"calibration": [], "navigation": []}
    on_progress(prog)
    if not todo:
        summary.failed = prog.failed
        summary.wall_s = time.perf_counter() - t0
        return summary
    if client is None:
        with dask_client(workers, scheduler, tls) as own:
            peak = _submit_all(own, spec, variants, todo, store, summary, prog, on_progress)
    else:
        peak = _submit_all(client, spec, variants, todo, store, summary, prog, on_progress)
    summary.failed = prog.failed
    summary.peak_mb = peak
    summary.wall_s = time.perf_counter() - t0
    return summary


__all__ = ["Progress", "RunSummary", "StudyFolderError", "StudyStore", "run_study"]
