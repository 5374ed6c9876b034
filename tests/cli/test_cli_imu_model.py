"""``rinscal fit --imu-cal`` and ``rinscal compensate`` with a model that holds an IMU
calibration: pulses in, deg/h and µg out, said in the metadata and on the terminal."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
from typer.testing import CliRunner

from rinscal.calibration.modelfile import ThermalModelFile
from rinscal.calibration.workflow import compensate, fit
from rinscal.cli import app
from rinscal.io.metadata import read_meta, write_meta
from rinscal.io.tables import write_log
from rinscal.schema import CHANNELS
from tests.calibration._imucal import calibration
from tests.calibration.test_imu_model import _with_errors

runner = CliRunner()


def test_fit_with_imu_cal_then_compensate(tmp_path, soak_small) -> None:
    log, _, meta = soak_small
    bad, bad_meta = _with_errors(log, meta)
    runs = list(dict.fromkeys(log["run"]))[:4]  # enough for a cubic, quick
    bad = bad[bad["run"].isin(runs)].reset_index(drop=True)
    src = tmp_path / "pulses.csv"
    write_log(bad, src)
    write_meta(bad_meta, src)
    imu = tmp_path / "imu.json"
    imu.write_text(
        json.dumps(
            {"schema": "rinscal.imu-calibration-file/1", "imu_calibration": calibration().to_dict()}
        )
    )
    model = tmp_path / "model.json"
    res = runner.invoke(
        app,
        ["fit", str(src), "--imu-cal", str(imu), "--method", "poly-t", "--orders", "2",
         "-o", str(model)],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "IMU calibration imu.json applied first" in res.output
    mf = ThermalModelFile.load(model)
    assert mf.imu_calibration == calibration()
    assert mf.models["gyro_x"].unit == "deg/h" and mf.imu_stage.input_units["gyro_x"] == "pulse"
    out = tmp_path / "comp.csv"
    res = runner.invoke(app, ["compensate", str(src), "-m", str(model), "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "deg/h (gyros) and ug (accelerometers)" in res.output
    got = read_meta(out)
    assert got["units"]["gyro_x"] == "deg/h" and got["units"]["accel_z"] == "ug"
    assert got["compensated"]["imu_calibration"] is True
    comp = pd.read_csv(out)
    # the error-free log, fitted and compensated alike, gives the same numbers
    clean = log[log["run"].isin(runs)].reset_index(drop=True)
    want = compensate(clean, fit(clean, "poly-t", meta=meta, orders=(2,)).model)
    for c in CHANNELS:
        scale = np.abs(want[c]).max()
        np.testing.assert_allclose(comp[c], want[c], rtol=0, atol=1e-9 * scale, err_msg=c)
    # the input is untouched; a log without a channel's temperature is refused, naming it
    assert pd.read_csv(src)["gyro_x"].equals(bad["gyro_x"])
    short = tmp_path / "short.csv"
    write_log(bad.drop(columns=["temp_gyro_y"]), short, validate=False)
    write_meta(bad_meta, short)
    res = runner.invoke(app, ["compensate", str(short), "-m", str(model), "-o", str(out)])
    assert res.exit_code != 0
    assert "temp_gyro_y" in res.output
    assert np.isfinite(comp[list(CHANNELS)].to_numpy()).all()
