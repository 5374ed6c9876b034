"""The Python API checks its arguments at the boundary and names the one it refuses.

Before, a wrong type or an empty table raised from deep inside (pandas ``KeyError: 'run'``,
numpy ``ufunc 'isfinite'``, ``AttributeError: 'str' object has no attribute 'output'``,
pathlib's ``TypeError``). Now each public function (``rinscal.__all__``) refuses it with the
project's errors: :class:`ArgumentTypeError` (a ``TypeError`` and a ``ValueError``) for a
wrong type, :class:`ConfigError` for a wrong value, :class:`LogError` for a table that is
empty or not a log; the message names the argument, what was given and what is accepted.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable
from typing import Any

import numpy as np
import pandas as pd
import pytest

import rinscal
from rinscal.errors import ArgumentTypeError, ConfigError, LogError, RinscalError

NO_CAL = rinscal.ImuCalibration(t0_c=20.0, t_range_c=(0.0, 50.0), t_coefs={})
TINY = {"hours": 0.05, "rate_hz": 0.5, "seed": 1, "imu": "navigation_grade"}


@pytest.fixture(scope="module")
def env(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """A tiny soak log, its file and a model fitted on it."""
    log, _, meta = rinscal.simulate("soak", **TINY)
    folder = tmp_path_factory.mktemp("args")
    path = folder / "soak.csv"
    rinscal.write_log(log, path)
    rinscal.write_meta(meta, path)
    model = rinscal.fit(log, "poly-t", meta=meta).model
    return {"log": log, "meta": meta, "path": path, "model": model, "dir": folder}


#: (case id, call of env, the error class, the argument the message must name)
Case = tuple[str, Callable[[dict[str, Any]], Any], type[Exception], str]
CASES: list[Case] = [
    # the five
    ("fit an empty table", lambda e: rinscal.fit(pd.DataFrame(), "regression"), LogError, "log"),
    (
        "simulate hours as text",
        lambda e: rinscal.simulate("soak", hours="0.05"),
        ArgumentTypeError,
        "hours",
    ),
    (
        "navigate rate as text",
        lambda e: rinscal.navigate("quasi-static", hours=0.05, rate_hz="20"),
        ArgumentTypeError,
        "rate_hz",
    ),
    (
        "simulate_multiposition imu a number",
        lambda e: rinscal.simulate_multiposition(42),
        ArgumentTypeError,
        "imu",
    ),
    (
        "evaluate model a number",
        lambda e: rinscal.evaluate(e["log"], 42),
        ArgumentTypeError,
        "model",
    ),
    # read_log, write_log, write_meta
    ("read_log path a number", lambda e: rinscal.read_log(42), ArgumentTypeError, "path"),
    (
        "read_log fmt a number",
        lambda e: rinscal.read_log(e["path"], fmt=3),
        ArgumentTypeError,
        "fmt",
    ),
    (
        "write_log df a dict",
        lambda e: rinscal.write_log({"a": 1}, e["dir"] / "x.csv"),
        ArgumentTypeError,
        "df",
    ),
    (
        "write_log path a number",
        lambda e: rinscal.write_log(e["log"], 42),
        ArgumentTypeError,
        "path",
    ),
    (
        "write_meta meta a string",
        lambda e: rinscal.write_meta("units", e["path"]),
        ArgumentTypeError,
        "meta",
    ),
    (
        "write_meta logpath None",
        lambda e: rinscal.write_meta({}, None),
        ArgumentTypeError,
        "logpath",
    ),
    # simulate, simulate_multiposition, load_imu
    ("simulate protocol a number", lambda e: rinscal.simulate(42), ArgumentTypeError, "protocol"),
    ("simulate unknown protocol", lambda e: rinscal.simulate("soaks"), ConfigError, "protocol"),
    (
        "simulate seed a fraction",
        lambda e: rinscal.simulate("soak", hours=0.05, seed=1.5),
        ArgumentTypeError,
        "seed",
    ),
    (
        "simulate negative hours",
        lambda e: rinscal.simulate("soak", hours=-1.0),
        ConfigError,
        "hours",
    ),
    (
        "simulate rate a bool",
        lambda e: rinscal.simulate("soak", hours=0.05, rate_hz=True),
        ArgumentTypeError,
        "rate_hz",
    ),
    (
        "simulate_multiposition dwell as text",
        lambda e: rinscal.simulate_multiposition(dwell_s="2"),
        ArgumentTypeError,
        "dwell_s",
    ),
    (
        "simulate_multiposition set points as text",
        lambda e: rinscal.simulate_multiposition(set_points_c="20"),
        ArgumentTypeError,
        "set_points_c",
    ),
    (
        "simulate_multiposition ramp as text",
        lambda e: rinscal.simulate_multiposition(ramp="yes"),
        ArgumentTypeError,
        "ramp",
    ),
    ("load_imu a number", lambda e: rinscal.load_imu(42), ArgumentTypeError, "spec"),
    # fit
    ("fit log a number", lambda e: rinscal.fit(42), ArgumentTypeError, "log"),
    (
        "fit a table with no rows",
        lambda e: rinscal.fit(e["log"].iloc[:0], "poly-t"),
        LogError,
        "log",
    ),
    (
        "fit a table without run",
        lambda e: rinscal.fit(e["log"].drop(columns="run"), "poly-t"),
        LogError,
        "log",
    ),
    ("fit method a number", lambda e: rinscal.fit(e["log"], 2), ArgumentTypeError, "method"),
    (
        "fit meta a string",
        lambda e: rinscal.fit(e["log"], "poly-t", meta="soak.meta.json"),
        ArgumentTypeError,
        "meta",
    ),
    (
        "fit window as text",
        lambda e: rinscal.fit(e["log"], "poly-t", window_s="60"),
        ArgumentTypeError,
        "window_s",
    ),
    (
        "fit orders as text",
        lambda e: rinscal.fit(e["log"], "regression", orders="333"),
        ArgumentTypeError,
        "orders",
    ),
    (
        "fit temp_range one number",
        lambda e: rinscal.fit(e["log"], temp_range=50.0),
        ArgumentTypeError,
        "temp_range",
    ),
    (
        "fit candidates a string",
        lambda e: rinscal.fit(e["log"], candidates="poly-t"),
        ArgumentTypeError,
        "candidates",
    ),
    (
        "fit imu_calibration a number",
        lambda e: rinscal.fit(e["log"], imu_calibration=1),
        ArgumentTypeError,
        "imu_calibration",
    ),
    # calibrate_imu
    (
        "calibrate_imu log a path",
        lambda e: rinscal.calibrate_imu(str(e["path"]), e["meta"]),
        ArgumentTypeError,
        "log",
    ),
    (
        "calibrate_imu an empty table",
        lambda e: rinscal.calibrate_imu(pd.DataFrame(), e["meta"]),
        LogError,
        "log",
    ),
    (
        "calibrate_imu meta a string",
        lambda e: rinscal.calibrate_imu(e["log"], "meta.json"),
        ArgumentTypeError,
        "meta",
    ),
    (
        "calibrate_imu settle as text",
        lambda e: rinscal.calibrate_imu(e["log"], e["meta"], settle_s="5"),
        ArgumentTypeError,
        "settle_s",
    ),
    # load_model, compensate, compensate_file, evaluate
    ("load_model a number", lambda e: rinscal.load_model(42), ArgumentTypeError, "path"),
    (
        "compensate log a number",
        lambda e: rinscal.compensate(42, e["model"]),
        ArgumentTypeError,
        "log",
    ),
    (
        "compensate an empty table",
        lambda e: rinscal.compensate(pd.DataFrame(), e["model"]),
        LogError,
        "log",
    ),
    (
        "compensate model a dict",
        lambda e: rinscal.compensate(e["log"], {}),
        ArgumentTypeError,
        "model",
    ),
    (
        "compensate policy a number",
        lambda e: rinscal.compensate(e["log"], e["model"], policy=1),
        ArgumentTypeError,
        "policy",
    ),
    (
        "compensate causal as text",
        lambda e: rinscal.compensate(e["log"], e["model"], causal="no"),
        ArgumentTypeError,
        "causal",
    ),
    (
        "compensate_file log a table",
        lambda e: rinscal.compensate_file(e["log"], e["model"], e["dir"] / "o.csv"),
        ArgumentTypeError,
        "log",
    ),
    (
        "compensate_file out a number",
        lambda e: rinscal.compensate_file(e["path"], e["model"], 7),
        ArgumentTypeError,
        "out",
    ),
    (
        "evaluate log a number",
        lambda e: rinscal.evaluate(3.0, e["model"]),
        ArgumentTypeError,
        "log",
    ),
    (
        "evaluate step window as text",
        lambda e: rinscal.evaluate(e["log"], e["model"], step_window_s="120"),
        ArgumentTypeError,
        "step_window_s",
    ),
    # select
    (
        "select log a path",
        lambda e: rinscal.select(str(e["path"]), "regression"),
        ArgumentTypeError,
        "log",
    ),
    (
        "select an empty table",
        lambda e: rinscal.select(pd.DataFrame(), "regression"),
        LogError,
        "log",
    ),
    ("select method a number", lambda e: rinscal.select(e["log"], 3), ArgumentTypeError, "method"),
    (
        "select tolerance as text",
        lambda e: rinscal.select(e["log"], "regression", tolerance="0.02"),
        ArgumentTypeError,
        "tolerance",
    ),
    # navigate, Scenario, scenario
    ("navigate scenario a number", lambda e: rinscal.navigate(42), ArgumentTypeError, "scenario"),
    ("navigate log a number", lambda e: rinscal.navigate(log=42), ArgumentTypeError, "log"),
    (
        "navigate models a string",
        lambda e: rinscal.navigate("quasi-static", models="m.json"),
        ArgumentTypeError,
        "models",
    ),
    (
        "navigate a model a number",
        lambda e: rinscal.navigate("quasi-static", models=[3]),
        ArgumentTypeError,
        "models[0]",
    ),
    (
        "navigate seed as text",
        lambda e: rinscal.navigate("quasi-static", seed="1"),
        ArgumentTypeError,
        "seed",
    ),
    (
        "navigate hours as text",
        lambda e: rinscal.navigate("quasi-static", hours="1"),
        ArgumentTypeError,
        "hours",
    ),
    (
        "navigate an unknown option",
        lambda e: rinscal.navigate("quasi-static", rate=20),
        ConfigError,
        "rate",
    ),
    (
        "navigate a recording, align as text",
        lambda e: rinscal.navigate(log=e["path"], align_s="600"),
        ArgumentTypeError,
        "align_s",
    ),
    (
        "navigate a recording, models a string",
        lambda e: rinscal.navigate(log=e["path"], models="m.json"),
        ArgumentTypeError,
        "models",
    ),
    ("scenario name a number", lambda e: rinscal.scenario(1), ArgumentTypeError, "name"),
    (
        "scenario hours as text",
        lambda e: rinscal.scenario("quasi-static", hours="1"),
        ArgumentTypeError,
        "hours",
    ),
    (
        "Scenario duration as text",
        lambda e: dataclasses.replace(rinscal.scenario("quasi-static"), duration_s="3600"),
        ArgumentTypeError,
        "duration_s",
    ),
    (
        "Scenario schedule a string",
        lambda e: dataclasses.replace(rinscal.scenario("quasi-static"), schedule="four-position"),
        ArgumentTypeError,
        "schedule",
    ),
    # the names of issue 37 (the old ones above stay for one release)
    (
        "navigate_scenario seed as text",
        lambda e: rinscal.navigate_scenario("quasi-static", seed="1"),
        ArgumentTypeError,
        "seed",
    ),
    (
        "navigate_log models a string",
        lambda e: rinscal.navigate_log(e["path"], models="m.json"),
        ArgumentTypeError,
        "models",
    ),
    (
        "paper_scenario name a number",
        lambda e: rinscal.paper_scenario(1),
        ArgumentTypeError,
        "name",
    ),
    (
        "ScenarioConfig duration as text",
        lambda e: dataclasses.replace(rinscal.paper_scenario("quasi-static"), duration_s="3600"),
        ArgumentTypeError,
        "duration_s",
    ),
    (
        "study units as text",
        lambda e: rinscal.study("paper", e["dir"] / "study", units="3"),
        ArgumentTypeError,
        "units",
    ),
    (
        "study progress a string",
        lambda e: rinscal.study("paper", e["dir"] / "study", progress="print"),
        ArgumentTypeError,
        "progress",
    ),
    (
        "reproduce seed as text",
        lambda e: rinscal.reproduce(e["dir"] / "repro", seed="1"),
        ArgumentTypeError,
        "seed",
    ),
    (
        "reproduce an unknown IMU",
        lambda e: rinscal.reproduce(e["dir"] / "repro", imu="no-such-imu"),
        ConfigError,
        "imu",
    ),
    (
        "select seed and random_state",
        lambda e: rinscal.select(e["log"], "regression", seed=1, random_state=1),
        ConfigError,
        "seed",
    ),
    (
        "fit progress a number",
        lambda e: rinscal.fit(e["log"], "poly-t", progress=1),
        ArgumentTypeError,
        "progress",
    ),
    # FitResult.save, ImuCalibration and its correct()
    (
        "FitResult.save path a number",
        lambda e: rinscal.fit(e["log"], "poly-t").save(5),
        ArgumentTypeError,
        "path",
    ),
    (
        "ImuCalibration.correct outputs as text",
        lambda e: NO_CAL.correct("0.1", np.full((1, 6), 20.0)),
        ArgumentTypeError,
        "y_si",
    ),
    (
        "ImuCalibration.correct five temperatures",
        lambda e: NO_CAL.correct(np.zeros((2, 6)), np.full((2, 5), 20.0)),
        ConfigError,
        "temp_c",
    ),
    (
        "ImuCalibration t0 as text",
        lambda e: rinscal.ImuCalibration(t0_c="20", t_range_c=(0.0, 50.0), t_coefs={}),
        ArgumentTypeError,
        "t0_c",
    ),
    (
        "ImuCalibration coefs a list",
        lambda e: rinscal.ImuCalibration(t0_c=20.0, t_range_c=(0.0, 50.0), t_coefs=[]),
        ArgumentTypeError,
        "t_coefs",
    ),
]


@pytest.mark.parametrize(("case", "call", "error", "name"), CASES, ids=[c[0] for c in CASES])
def test_a_bad_argument_is_refused_naming_it(
    env: dict[str, Any], case: str, call: Callable, error: type[Exception], name: str
) -> None:
    with pytest.raises(RinscalError) as exc:
        call(env)
    assert type(exc.value) is error, f"{case}: {type(exc.value).__name__}: {exc.value}"
    msg = str(exc.value)
    assert re.search(rf"(^|\W){re.escape(name)}($|\W)", msg), f"{case}: {msg!r} names no {name}"
    if error is ArgumentTypeError:  # what was given, and what is accepted
        assert "expected" in msg and "got" in msg, msg
        assert isinstance(exc.value, TypeError) and isinstance(exc.value, ValueError)
    assert "Traceback" not in msg and len(msg) < 400


def test_every_public_callable_has_a_case() -> None:
    """Each function or class of the API that takes user arguments is in the table."""
    covered = {c[0].split()[0].split(".")[0] for c in CASES}
    takes_arguments = {
        "read_log", "write_log", "write_meta", "simulate", "simulate_multiposition", "load_imu",
        "fit", "calibrate_imu", "load_model", "compensate", "compensate_file", "evaluate",
        "select", "navigate_scenario", "navigate_log", "paper_scenario", "ScenarioConfig",
        "study", "reproduce", "ImuCalibration",
    }  # fmt: skip
    old_names = {"navigate", "scenario", "Scenario"}  # kept for one release, not in __all__
    assert takes_arguments <= set(rinscal.__all__)
    assert old_names <= set(rinscal._ALIASES) and not old_names & set(rinscal.__all__)
    assert takes_arguments | old_names <= covered, (takes_arguments | old_names) - covered


def test_a_number_given_as_text_is_not_converted() -> None:
    with pytest.raises(ArgumentTypeError) as exc:
        rinscal.simulate("soak", hours="0.05")
    msg = str(exc.value)
    assert msg.startswith("hours: expected a number")
    assert "str '0.05'" in msg and "give 0.05 without quotes" in msg


def test_an_empty_table_says_it_has_no_rows() -> None:
    with pytest.raises(LogError, match=r"^log has no rows"):
        rinscal.fit(pd.DataFrame(), "regression")
    with pytest.raises(ValueError, match=r"^log has no rows"):  # a ValueError still
        rinscal.select(pd.DataFrame(columns=["time_s", "run"]), "regression")


def test_a_long_value_is_shortened_in_the_message(env: dict[str, Any]) -> None:
    with pytest.raises(ArgumentTypeError) as exc:
        rinscal.load_model(list(range(1000)))
    msg = str(exc.value)
    assert msg.startswith("path: expected a path") and "list [0, 1, 2" in msg and len(msg) < 200


def test_good_arguments_of_other_numeric_types_still_work(env: dict[str, Any]) -> None:
    """numpy scalars and ints where floats are asked (what a notebook computes) are taken."""
    log, _, meta = rinscal.simulate("soak", hours=np.float64(0.02), rate_hz=1, seed=np.int64(2))
    assert meta["seed"] == 2 and len(log) == 7 * 72
    ev = rinscal.evaluate(env["log"], env["model"], step_window_s=np.float32(60))
    assert len(ev.table) > 0
