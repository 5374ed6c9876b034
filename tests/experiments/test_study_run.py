"""Running a study on Dask: the same results on 1 and 2 workers, a killed client resumes
without recomputing what finished, a task that raises is recorded and the rest finish."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pandas as pd
import pytest

from rinscal.experiments.study import runner
from rinscal.experiments.study.runner import StudyFolderError, StudyStore, run_study
from rinscal.experiments.study.spec import load_spec, spec_from_dict
from rinscal.experiments.study.tasks import RESULT_COLUMNS, study_tasks

#: A study small enough for the default suite: 4 units × 3 cold starts of 0.3 h at 5 Hz,
#: calibrated on 0.5 h soak runs at 1 Hz (16 tasks, each well under a second).
TINY = """
[study]
name = "tiny"
seed = 1
units = 4
coefficient_spread = 0.1
methods = ["none", "poly-t", "regression", "true"]

[calibration]
hours = 0.5
rate_hz = 1.0

[[plants]]
imu = "paper"

[[scenarios]]
name = "qs"
kind = "quasi-static"
hours = 0.3
rate_hz = 5.0
ambient_c = [18.0, 22.0, 26.0]
align_s = 120.0
"""
#: Columns a result must reproduce exactly (not the run times or memory of the worker).
EXACT = [c for c in RESULT_COLUMNS if c != "elapsed_s"]
CMD = [sys.executable, "-c", "from rinscal.cli import main; main()", "study"]


@pytest.fixture(scope="module")
def tiny_spec(tmp_path_factory: pytest.TempPathFactory) -> Path:
    p = tmp_path_factory.mktemp("spec") / "tiny.toml"
    p.write_text(TINY)
    return p


def _table(out: Path, spec: Path) -> pd.DataFrame:
    df = StudyStore(out).read_results(load_spec(spec))
    return (
        df[EXACT]
        .sort_values(["plant", "unit", "scenario", "start", "variant"])
        .reset_index(drop=True)
    )


@pytest.fixture(scope="module")
def one_worker(tiny_spec: Path, tmp_path_factory: pytest.TempPathFactory) -> pd.DataFrame:
    out = tmp_path_factory.mktemp("w1") / "study"
    r = subprocess.run(
        [*CMD, str(tiny_spec), "--out", str(out), "--workers", "1"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stdout + r.stderr
    assert "computed 16 task(s)" in r.stdout
    assert (out / "report.html").is_file() and (out / "tables" / "method_summary.csv").is_file()
    # claims.csv beside the report: 4 units are below the rule's minimum, and it says so
    claims = pd.read_csv(out / "claims.csv")
    assert list(claims.columns) == [
        "claim", "plant", "group", "n", "mean_nmi", "ci_low_nmi", "ci_high_nmi", "verdict"
    ]  # fmt: skip
    assert len(claims) > 0 and set(claims["verdict"]) == {"not enough runs"}
    assert (claims["n"] == 4).all() and claims["ci_low_nmi"].isna().all()
    assert "not enough runs (n = 4 units; needs 5)" in " ".join(r.stdout.split())
    table = _table(out, tiny_spec)
    assert len(table) == 4 * 3 * 4  # units × starts × variants
    return table


def test_runs_unchanged_on_an_existing_cluster(
    one_worker: pd.DataFrame, tiny_spec: Path, tmp_path: Path
) -> None:
    """--scheduler: the command is only the client; the tasks run on the cluster's worker."""
    from distributed import LocalCluster

    out = tmp_path / "study"
    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", dashboard_address=":0"
    ) as cluster:
        address = cluster.scheduler_address
        r = subprocess.run(
            [*CMD, str(tiny_spec), "--out", str(out), "--scheduler", address],
            capture_output=True,
            text=True,
            timeout=300,
        )
    assert r.returncode == 0, r.stdout + r.stderr
    assert f"on cluster {address}" in r.stdout.replace("\n", "")
    pd.testing.assert_frame_equal(_table(out, tiny_spec), one_worker, check_exact=True)


def test_killed_client_resumes_without_recomputing_and_two_workers_match_one(
    one_worker: pd.DataFrame, tiny_spec: Path, tmp_path: Path
) -> None:
    """A study on 2 workers, its client killed with SIGKILL mid-way (with its scheduler and
    workers), resumed with the same command: the finished runs are not computed again and
    the final table is bit for bit the uninterrupted 1-worker study's."""
    out = tmp_path / "study"
    results = out / "results"
    proc = subprocess.Popen(
        [*CMD, str(tiny_spec), "--out", str(out), "--workers", "2"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    deadline = time.monotonic() + 240
    try:
        while time.monotonic() < deadline:
            if len(list(results.glob("*/*.parquet"))) >= 4 or proc.poll() is not None:
                break
            time.sleep(0.02)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the client, its scheduler and its workers
        proc.wait()
    assert proc.returncode == -signal.SIGKILL, "the study ended before it could be killed"
    finished = {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in results.glob("*/*.parquet")}
    assert 4 <= len(finished) < 12
    spec = load_spec(tiny_spec)
    store = StudyStore(out)
    n_missing = 0
    for cal, navs in study_tasks(spec):
        missing = [t for t in navs if not store.has_result(t)]
        n_missing += len(missing) + (bool(missing) and not store.model_path(cal).is_file())
    r = subprocess.run(
        [*CMD, str(tiny_spec), "--out", str(out), "--workers", "2"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stdout + r.stderr
    assert "resumed:" in r.stdout and "on 2 worker(s)" in r.stdout
    for p, stamp in finished.items():  # not computed (nor written) again
        assert (p.stat().st_ino, p.stat().st_mtime_ns) == stamp, p
    # exactly the missing runs, and the calibrations of units whose models were not saved
    assert f"computed {n_missing} task(s)" in r.stdout
    pd.testing.assert_frame_equal(_table(out, tiny_spec), one_worker, check_exact=True)


def test_a_task_that_raises_is_recorded_and_the_others_finish(
    tiny_spec: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from distributed import Client

    spec = load_spec(tiny_spec, units_override=2)
    store = StudyStore(tmp_path / "study")
    real = runner.navigate_unit

    def flaky(spec, plant, task, cal):
        if task.key == "nav-p000-u00001-s00-r01":
            raise RuntimeError("simulated worker fault")
        return real(spec, plant, task, cal)

    monkeypatch.setattr(runner, "navigate_unit", flaky)
    with Client(
        processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0"
    ) as client:
        run = run_study(spec, store, client=client)
        assert (run.computed, run.failed) == (2 + 5, 1)
        fails = store.failures()
        assert list(fails["task"]) == ["nav-p000-u00001-s00-r01"]
        assert "RuntimeError: simulated worker fault" in fails["error"].iloc[0]
        assert len(store.read_results(spec)) == 5 * 4
        # the same command again: nothing to do, the failure stays recorded
        again = run_study(spec, store, client=client)
        assert (again.computed, again.failed, again.skipped) == (0, 1, 7)
        # the fault is gone: --retry-failed runs just that task (its unit's models are kept)
        monkeypatch.setattr(runner, "navigate_unit", real)
        retry = run_study(spec, store, client=client, retry_failed=True)
        assert (retry.computed, retry.failed) == (1, 0)
        assert store.failures().empty
        # more units later: only the new unit's tasks run
        more = run_study(load_spec(tiny_spec, units_override=3), store, client=client)
        assert (more.computed, more.skipped) == (4, 8)


def test_a_failing_calibration_fails_its_runs_with_its_reason(
    tiny_spec: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from distributed import Client

    spec = load_spec(tiny_spec, units_override=1)
    store = StudyStore(tmp_path / "study")

    def broken(*_a, **_k):
        raise ValueError("soak log unusable")

    monkeypatch.setattr(runner, "calibrate_unit", broken)
    with Client(
        processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0"
    ) as client:
        run = run_study(spec, store, client=client)
    assert (run.computed, run.failed) == (0, 4)
    errors = store.failures().set_index("task")["error"]
    assert errors["cal-p000-u00000"] == "ValueError: soak log unusable"
    assert errors["nav-p000-u00000-s00-r02"].startswith(
        "calibration cal-p000-u00000 failed: ValueError: soak log unusable"
    )


def test_a_folder_holds_one_study(tiny_spec: Path, tmp_path: Path) -> None:
    spec = load_spec(tiny_spec)
    store = StudyStore(tmp_path / "study")
    assert store.open(spec) is False
    assert store.open(load_spec(tiny_spec, units_override=9)) is True  # more units: same study
    data = tomllib.loads(TINY)
    data["study"]["seed"] = 2
    other = spec_from_dict(data, "other")
    with pytest.raises(StudyFolderError, match="holds study 'tiny' with other settings"):
        store.open(other)
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "notes.txt").write_text("mine")
    with pytest.raises(StudyFolderError, match=r"is not empty and holds no study\.json"):
        StudyStore(tmp_path / "busy").open(spec)
    (tmp_path / "file").write_text("x")
    with pytest.raises(StudyFolderError, match="exists and is not a folder"):
        StudyStore(tmp_path / "file").open(spec)


def test_each_run_reports_the_model_s_residual_on_the_cold_start(
    one_worker: pd.DataFrame,
) -> None:
    """Issue 23, item 4: no compensation leaves the whole thermal swing, the oracle none,
    and a model something in between that is its own (not a copy of another's)."""
    by = one_worker.groupby("variant")
    pct = by["accel_residual_pct"]
    assert (pct.min()["none"], pct.max()["none"]) == (pytest.approx(100.0), pytest.approx(100.0))
    assert pct.max()["true"] == 0.0 and by["gyro_residual_dph"].max()["true"] == 0.0
    models = one_worker[one_worker["variant"].isin(["poly-t", "regression"])]
    assert (
        models[["accel_residual_pct", "accel_residual_ug", "gyro_residual_dph"]].gt(0).all().all()
    )
    assert pct.mean()["regression"] < 100.0  # the paper's own law: the regression follows it
    assert pct.mean()["regression"] != pct.mean()["poly-t"]
