"""`rinscal navigate`: files written, numbers consistent, inputs never overwritten."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from rinscal.cli import app

runner = CliRunner()


def test_navigate_quasi_static_writes_errors_summary_and_plots(tmp_path) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "qs"
    args = ["navigate", "--scenario", "quasi-static", "--hours", "0.3", "--rate", "10"]
    res = runner.invoke(app, [*args, "--seed", "4", "--out", str(out)])
    assert res.exit_code == 0, res.output
    for name in (
        "errors.csv",
        "truth.csv",
        "summary.json",
        "position_error.png",
        "trajectory.png",
        "temperatures.png",
    ):
        assert (out / name).stat().st_size > 0, name
    err = pd.read_csv(out / "errors.csv")
    summary = json.loads((out / "summary.json").read_text())
    assert set(err["variant"]) == {"none", "true"}
    # reported from the end of the 10-min alignment to the end, once per second
    none = err[err["variant"] == "none"]
    assert none["time_s"].iloc[0] == 601.0 and none["time_s"].iloc[-1] == 1080.0
    np.testing.assert_allclose(none["horizontal_m"], np.hypot(none["east_m"], none["north_m"]))
    np.testing.assert_allclose(none["horizontal_nmi"] * 1852.0, none["horizontal_m"])
    assert summary["variants"]["none"]["max_error_m"] == pytest.approx(
        none["horizontal_m"].max(), rel=1e-9
    )
    assert summary["seed"] == 4 and summary["scenario"] == "quasi-static"
    assert "max position error" in res.output
    # same seed, same numbers (deterministic); existing outputs are replaced atomically
    res2 = runner.invoke(app, [*args, "--seed", "4", "--out", str(out)])
    assert res2.exit_code == 0, res2.output
    pd.testing.assert_frame_equal(pd.read_csv(out / "errors.csv"), err)


def test_navigate_vehicle_reports_a_moving_truth(tmp_path) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "veh"
    res = runner.invoke(
        app,
        [
            "navigate",
            "-s",
            "vehicle",
            "--hours",
            "0.15",
            "--rate",
            "20",
            "--no-oracle",
            "--out",
            str(out),
        ],
    )
    assert res.exit_code == 0, res.output
    truth = pd.read_csv(out / "truth.csv")
    err = pd.read_csv(out / "errors.csv")
    assert set(err["variant"]) == {"none"}
    speed = np.hypot(truth["v_e"], truth["v_n"])
    assert speed.max() > 10.0 and truth["alt_m"].max() > truth["alt_m"].min() + 1.0


def test_navigate_refuses_bad_input_and_never_overwrites_it(tmp_path) -> None:  # type: ignore[no-untyped-def]
    res = runner.invoke(app, ["navigate", "-s", "moon", "--out", str(tmp_path / "x")])
    assert res.exit_code == 2
    assert "unknown scenario 'moon'" in res.output
    res = runner.invoke(
        app, ["navigate", "-s", "ramp", "-m", str(tmp_path / "no.json"), "--out", str(tmp_path)]
    )
    assert res.exit_code == 2 and "not found" in res.output
    model = tmp_path / "summary.json"
    model.write_text("{}")
    res = runner.invoke(
        app,
        [
            "navigate",
            "-s",
            "quasi-static",
            "--hours",
            "0.3",
            "-m",
            str(model),
            "--out",
            str(tmp_path),
        ],
    )
    assert res.exit_code == 2 and "refusing to overwrite" in res.output
    assert model.read_text() == "{}"
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    res = runner.invoke(
        app,
        [
            "navigate",
            "-s",
            "quasi-static",
            "--hours",
            "0.3",
            "--rate",
            "10",
            "-m",
            str(bad),
            "--out",
            str(tmp_path / "o"),
        ],
    )
    assert res.exit_code == 2 and "bad.json" in res.output
