"""The package's API (issue 37): each function listed once by ``help(rinscal)``, old names
kept as the same objects outside ``__all__``, one ``progress(done, total)`` convention,
``seed=`` at the top, deprecated keywords that still work and say so."""

from __future__ import annotations

import math
import pydoc
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import rinscal

#: The functions issue 37 names, one signature each.
FUNCTIONS = (
    "simulate", "navigate_scenario", "navigate_log", "fit", "select", "compensate", "evaluate",
    "calibrate_imu", "study", "reproduce",
)  # fmt: skip
OLD = ("navigate", "scenario", "Scenario", "ThermalModel", "ThermalModelFile")
ESTIMATORS = ("PolyT", "Regression", "Sectional", "Neural", "PX4Fit", "ArduPilotFit")
TINY = {"hours": 0.05, "rate_hz": 0.5, "seed": 1}


def _help_text() -> str:
    return pydoc.render_doc(rinscal, renderer=pydoc.plaintext)


def _section(text: str, name: str) -> str:
    """One top-level section (``FUNCTIONS``, ``CLASSES``) of a pydoc page."""
    m = re.search(rf"^{name}\n(.*?)(?=^[A-Z]+\n|\Z)", text, flags=re.M | re.S)
    return m.group(1) if m else ""


def test_help_lists_each_function_once_and_no_old_name() -> None:
    text = _help_text()
    # a function defined under another name shows as "select = select_model(...)"
    functions = re.findall(r"^    (\w+)(?: = \w+)?\(", _section(text, "FUNCTIONS"), flags=re.M)
    assert len(functions) == len(set(functions)), sorted(functions)
    assert set(FUNCTIONS) <= set(functions)
    classes = set(re.findall(r"^    class (\w+)", _section(text, "CLASSES"), flags=re.M))
    assert set(ESTIMATORS) <= classes
    for name in OLD:
        assert not re.search(rf"^    (class )?{name}\b", text, flags=re.M), name
    assert not set(OLD) & set(rinscal.__all__)


def test_old_names_are_the_new_objects() -> None:
    assert rinscal.Scenario is rinscal.ScenarioConfig
    assert rinscal.scenario is rinscal.paper_scenario
    assert rinscal.ThermalModel is rinscal.ThermalFitter
    assert rinscal.ThermalModelFile is rinscal.FittedModel
    cfg = rinscal.scenario("quasi-static", hours=0.5, rate_hz=10.0)
    assert cfg == rinscal.paper_scenario("quasi-static", hours=0.5, rate_hz=10.0)
    assert cfg.duration_s == pytest.approx(1800.0)


def test_the_six_estimators_are_exported() -> None:
    from sklearn.base import RegressorMixin

    from rinscal.calibration.thermal.estimators import ALL_ESTIMATORS

    exported = {getattr(rinscal, n) for n in ESTIMATORS}
    assert exported == set(ALL_ESTIMATORS.values())
    assert all(issubclass(e, RegressorMixin) for e in exported)


def test_simulate_is_typed_and_unpacks_as_before() -> None:
    sim = rinscal.simulate("repeat", **TINY)
    log, truth, meta = sim
    assert isinstance(sim, rinscal.Simulation)
    assert sim.log is log and sim.truth is truth and sim.meta is meta
    assert meta["imu"] == rinscal.load_imu("paper").name  # the one default IMU
    assert len(log) == len(truth) == 0.05 * 3600 * 0.5


@pytest.fixture(scope="module")
def soak(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, int]:
    log, _, meta = rinscal.simulate("soak", **TINY)
    path = tmp_path_factory.mktemp("api") / "soak.csv"
    rinscal.write_log(log, path)
    rinscal.write_meta(meta, path)
    return path, int(log["run"].nunique())


def test_fit_reports_progress_as_done_and_total(soak: tuple[Path, int]) -> None:
    path, n_runs = soak
    calls: list[tuple[float, float]] = []
    rinscal.fit(path, "poly-t", progress=lambda d, t: calls.append((d, t)))
    reading = [d for d, t in calls if math.isnan(t)]
    fitting = [(d, t) for d, t in calls if not math.isnan(t)]
    assert reading == list(range(1, n_runs + 1))  # runs read; their number unknown ahead
    assert fitting == [(k, 6.0) for k in range(1, 7)]  # six channels fitted, of six


def test_old_progress_hooks_still_work_and_warn(soak: tuple[Path, int]) -> None:
    path, n_runs = soak
    runs: list[int] = []
    channels: list[str] = []
    with pytest.warns(DeprecationWarning, match="on_run"):
        rinscal.fit(path, "poly-t", on_run=runs.append, on_channel=lambda c, n: channels.append(c))
    assert runs == list(range(1, n_runs + 1))
    assert channels == ["gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"]


def test_select_takes_seed_and_random_state_is_its_old_name(soak: tuple[Path, int]) -> None:
    log = rinscal.read_log(soak[0])
    calls: list[tuple[float, float]] = []
    new = rinscal.select(
        log, "regression", [1, 2], seed=3, progress=lambda d, t: calls.append((d, t))
    )
    assert calls == [(k, 12.0) for k in range(1, 13)]  # 6 channels × 2 settings
    with pytest.warns(DeprecationWarning, match="random_state= is now seed="):
        old = rinscal.select(log, "regression", [1, 2], random_state=3)
    np.testing.assert_array_equal(new.table["rms_heldout"], old.table["rms_heldout"])
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)  # the new spelling does not warn
        rinscal.select(log, "regression", [1], seed=3)


def test_navigate_log_reports_seconds_read_then_navigated(tmp_path: Path) -> None:
    run = tmp_path / "run.parquet"
    rinscal.navigate_scenario(
        "quasi-static", hours=0.05, rate_hz=5.0, align_s=60.0, oracle=False, record=run
    )
    calls: list[tuple[float, float]] = []
    nav = rinscal.navigate_log(run, align_s=60.0, progress=lambda d, t: calls.append((d, t)))
    reading = [d for d, t in calls if math.isnan(t)]
    navigating = [(d, t) for d, t in calls if not math.isnan(t)]
    assert reading and navigating
    assert reading == sorted(reading) and reading[-1] == pytest.approx(180.0, abs=0.2)
    last, total = navigating[-1]
    assert last == pytest.approx(total) and total == pytest.approx(reading[-1])
    old = rinscal.navigate(log=run, align_s=60.0)  # the old name dispatches to navigate_log
    assert old.result.summary() == nav.result.summary()
    # the IMU whose noise the filter assumes: a name or an ImuConfig, the same filter
    by_name = rinscal.navigate_log(run, align_s=60.0, imu="navigation_grade")
    by_config = rinscal.navigate_log(run, align_s=60.0, imu=rinscal.load_imu("navigation_grade"))
    assert by_config.result.summary() == by_name.result.summary() != nav.result.summary()


def test_study_runs_and_writes_its_report_in_one_call(tmp_path: Path) -> None:
    """The tiny study of tests/experiments/test_study_run.py, one unit: 1 calibration and 3
    navigation tasks; progress counts them, the report is written, a second call resumes."""
    from tests.experiments.test_study_run import TINY as TINY_STUDY

    spec = tmp_path / "tiny.toml"
    spec.write_text(TINY_STUDY)
    calls: list[tuple[float, float]] = []
    out = tmp_path / "study"
    done = rinscal.study(spec, out, units=1, workers=1, progress=lambda d, t: calls.append((d, t)))
    assert calls[-1] == (4.0, 4.0) and [d for d, _ in calls] == sorted(d for d, _ in calls)
    assert (done.run.computed, done.run.failed) == (4, 0)
    assert done.written.report == out / "report.html" and done.written.report.is_file()
    again = rinscal.study(spec, out, units=1, workers=1)
    assert (again.run.computed, again.run.skipped) == (0, 4)


def test_simulate_config_is_the_old_name_of_imu() -> None:
    with pytest.warns(DeprecationWarning, match="config= is deprecated") as caught:
        old = rinscal.simulate("repeat", **TINY, config="navigation_grade")
    assert caught[0].filename == __file__  # pointed at the caller, not into the library
    new = rinscal.simulate("repeat", **TINY, imu="navigation_grade")
    assert old.meta["imu"] == new.meta["imu"] != rinscal.load_imu("paper").name
    assert old.log.equals(new.log)


def test_a_reproduction_is_planned_and_checked_before_any_work(tmp_path: Path) -> None:
    """The quick reproduction's steps: the calibration's 10, its 14 navigation runs (the ramp,
    5 quasi-static, 5 swing and 3 vehicle cold starts, as the paper's Section 5), the report;
    with units, every study task too. A bad setting is refused before the folder exists."""
    from rinscal.experiments.paper.run import CALIBRATION_STEPS, plan_reproduction

    plan = plan_reproduction(quick=True)
    assert plan.navigation_runs == 1 + 5 + 5 + 3
    assert plan.steps == CALIBRATION_STEPS + 14 + 1 and plan.study is None
    with_units = plan_reproduction(quick=True, units=2)
    assert with_units.study is not None and with_units.study.units == 2
    assert with_units.steps > plan.steps
    out = tmp_path / "repro"
    with pytest.raises(rinscal.errors.ConfigError, match="align"):
        rinscal.reproduce(out, quick=True, align_s=-1.0)
    assert not out.exists()


@pytest.mark.slow
def test_reproduce_writes_the_report_and_counts_its_steps(tmp_path: Path) -> None:
    calls: list[tuple[float, float]] = []
    rep = rinscal.reproduce(tmp_path, quick=True, progress=lambda d, t: calls.append((d, t)))
    steps = float(rep.run.plan.steps)
    assert calls[-1] == (steps, steps) and [d for d, _ in calls] == sorted(d for d, _ in calls)
    assert rep.written.report_path.is_file() and "total" in rep.metrics["timings_s"]
    assert len(rep.run.navigation) == rep.run.plan.navigation_runs
    assert rep.claims and all(isinstance(c["holds"], bool) for c in rep.claims.values())
