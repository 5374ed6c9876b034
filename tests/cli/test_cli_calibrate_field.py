"""`rinscal calibrate-field RUN... --out M.json`: parked cold starts in, a model file and
its report out (the same model file as fit's, used by navigate unchanged); bad input named."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

import rinscal
from rinscal.cli import app
from rinscal.cli.fieldcal import calibrate_field_cmd

runner = CliRunner()


@pytest.fixture(scope="module")
def starts(tmp_path_factory) -> list[Path]:  # type: ignore[no-untyped-def]
    """Three parked starts of the paper IMU at 0, 20 and 40 °C, 0.3 h at 10 Hz."""
    d = tmp_path_factory.mktemp("field")
    return rinscal.simulate_field_starts(
        d, runs=3, ambient_c=(0.0, 20.0, 40.0), hours=0.3, rate_hz=10.0, seed=3
    )


def test_calibrate_field_writes_a_model_navigate_reads(starts, tmp_path) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "field.json"
    res = runner.invoke(app, ["calibrate-field", *map(str, starts), "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "wrote" in res.output and out.is_file()
    model = rinscal.load_model(out)
    assert model.channels == ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
    assert model.source["protocol"] == "field"
    rep = json.loads((tmp_path / "field.field.json").read_text())
    assert set(rep["starts"]) == {p.stem for p in starts}
    terms = {(r["channel"], r["term"]) for r in rep["observability"]}
    assert ("accel_x", "dT") in terms and ("gyro_z", "Tdot") in terms
    # the inputs are untouched, and a model file is what navigate --model takes
    nav = runner.invoke(app, ["navigate", "--log", str(starts[0]), "--model", str(out),
                              "--align-s", "300", "--out", str(tmp_path / "nav")])  # fmt: skip
    assert nav.exit_code == 0, nav.output
    assert "field" in json.loads((tmp_path / "nav" / "summary.json").read_text())["variants"]


def test_calibrate_field_refuses_what_it_cannot_use(starts, tmp_path) -> None:  # type: ignore[no-untyped-def]
    res = runner.invoke(app, ["calibrate-field", *map(str, starts[:2]), "--out",
                              str(tmp_path / "m.json")])  # fmt: skip
    assert res.exit_code != 0 and "at least 3" in res.output
    res = runner.invoke(app, ["calibrate-field", *map(str, starts), "--out", str(starts[0])])
    assert res.exit_code != 0 and "JSON" in res.output
    res = runner.invoke(app, ["calibrate-field", *map(str, starts), str(tmp_path / "nope.parquet"),
                              "--out", str(tmp_path / "m.json")])  # fmt: skip
    assert res.exit_code != 0 and "nope.parquet: file not found" in res.output
    res = runner.invoke(app, ["calibrate-field", *map(str, starts), "--span", "40,10",
                              "--out", str(tmp_path / "m.json")])  # fmt: skip
    assert res.exit_code != 0 and "LO < HI" in res.output
    # a chamber soak is a calibration log, named as navigate names it, before it is read
    soak = tmp_path / "soak.parquet"
    made = runner.invoke(app, ["simulate", "soak", "--rate", "1", "--hours", "0.2",
                               "--out", str(soak)])  # fmt: skip
    assert made.exit_code == 0, made.output
    res = runner.invoke(app, ["calibrate-field", *map(str, starts[:2]), str(soak),
                              "--out", str(tmp_path / "m.json")])  # fmt: skip
    assert res.exit_code != 0, res.output
    assert "soak.parquet is a thermal calibration log" in res.output
    assert "rinscal fit" in res.output and not (tmp_path / "m.json").exists()


def test_the_command_is_registered_in_workflow_order() -> None:
    names = [c.name for c in app.registered_commands]
    assert "calibrate-field" in names and names.index("calibrate-field") > names.index("fit")
    assert any(c.callback.__wrapped__ is calibrate_field_cmd  # type: ignore[union-attr]
               if hasattr(c.callback, "__wrapped__") else c.callback is calibrate_field_cmd
               for c in app.registered_commands)  # fmt: skip
