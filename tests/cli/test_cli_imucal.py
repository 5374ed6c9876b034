"""rinscal calibrate-imu: writes imu.json and imu.params.csv that read back; errors named."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from rinscal.cli.commands import app
from rinscal.io.metadata import write_meta
from rinscal.io.params import read_params
from rinscal.io.tables import write_log
from rinscal.sensormodel import ImuCalibration
from tests.calibration._imu_synth import Design, make_log, paper_like_truth

runner = CliRunner()


def _files(tmp_path, **kw):
    log, meta, truth = make_log(
        paper_like_truth(), (10.0, 25.0, 40.0), design=Design(dwell_s=12.0, turns=1), seed=3, **kw
    )
    path = tmp_path / "cal.parquet"
    write_log(log, path)
    write_meta(meta, path)
    return path, truth


def test_writes_the_calibration_and_the_table_that_read_back(tmp_path):
    path, truth = _files(tmp_path)
    out = tmp_path / "imu.json"
    r = runner.invoke(app, ["calibrate-imu", str(path), "--out", str(out), "--settle", "3"])
    assert r.exit_code == 0, r.output
    data = json.loads(out.read_text())
    assert data["schema"] == "rinscal.imu-calibration-file/2"
    assert data["log"] == "cal.parquet" and data["generator"].startswith("rinscal calibrate-imu")
    cal = ImuCalibration.from_dict(data["imu_calibration"], str(out))
    assert len(cal.t_coefs) == 33 and 10.0 < cal.t0_c < 42.0
    assert {law["parameter"] for law in data["laws"]} == set(cal.t_coefs)
    table = read_params(tmp_path / "imu.params.csv")
    assert sorted(table.temperature_c.unique()) == [10.0, 25.0, 40.0]
    joined = table.merge(truth, on=["temperature_c", "parameter"], suffixes=("", "_t"))
    assert len(joined) == 99
    assert ((joined.value - joined.value_t).abs() < 5 * joined.sd).all()
    assert "gyro_sf_x" in r.output and "±" in r.output and "wrote" in r.output


def test_errors_are_messages_naming_the_file_and_run(tmp_path):
    path, _ = _files(tmp_path, creep=("cal_+25C", 3, 0.002))
    out = tmp_path / "imu.json"
    r = runner.invoke(app, ["calibrate-imu", str(path), "--out", str(out), "--settle", "3"])
    assert r.exit_code == 2
    assert "cal.parquet" in r.output and "run cal_+25C" in r.output and "position 3" in r.output
    assert "Traceback" not in r.output and not out.exists()
    r = runner.invoke(app, ["calibrate-imu", str(path), "--out", str(path)])
    assert r.exit_code == 2 and "refusing to overwrite the input" in r.output
