"""Issue 34.3: ``navigate --log`` with a model file that holds an IMU calibration made from
pulses refuses a recording in deg/h and µg (it would correct the scale factors twice),
naming both units, before reading the data."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
from typer.testing import CliRunner

from rinscal.cli.commands import app
from rinscal.io.metadata import write_meta
from rinscal.io.tables import write_log
from rinscal.schema import CHANNELS
from tests.calibration._imu_synth import Design, make_log, paper_like_truth

runner = CliRunner()


def test_navigate_log_refuses_a_recording_in_other_units_than_the_calibration(
    tmp_path, monkeypatch
):
    monkeypatch.chdir(tmp_path)
    log, meta, _ = make_log(
        paper_like_truth(), (10.0, 25.0), design=Design(dwell_s=12.0, turns=1), seed=3
    )
    write_log(log, "cal.parquet")
    write_meta(meta, "cal.parquet")
    r = runner.invoke(
        app,
        ["calibrate-imu", "cal.parquet", "-o", "imu.json", "--settle", "3", "--max-degree", "1"],
    )
    assert r.exit_code == 0, r.output
    r = runner.invoke(
        app,
        ["fit", "cal.parquet", "--imu-cal", "imu.json", "--method", "poly-t", "--orders", "1",
         "-o", "model.json"],
    )  # fmt: skip
    assert r.exit_code == 0, r.output
    # a short recording already in deg/h and µg (a factory-calibrated unit)
    n = 200
    rec = pd.DataFrame({"time_s": np.arange(1, n + 1) * 0.5})
    for c in CHANNELS:
        rec[c] = 9.0 if c.startswith("gyro") else (9.8e5 if c == "accel_z" else 0.0)
    for c in CHANNELS:
        rec[f"temp_{c}"] = 25.0
    rec.to_parquet("run.parquet")
    (tmp_path / "run.parquet.meta.json").write_text(
        json.dumps(
            {
                "kind": "navigation recording",
                "units": {"gyro": "deg/h", "accel": "ug"},
                "site": {"lat_deg": 32.06, "lon_deg": 118.78, "h_m": 10.0},
                "rate_hz": 2.0,
            }
        )
    )
    r = runner.invoke(
        app, ["navigate", "--log", "run.parquet", "--model", "model.json", "--out", "nav"]
    )
    assert r.exit_code != 0
    out = " ".join(r.output.split())
    assert "its units differ from the raw units of the IMU calibration of model.json" in out
    assert "gyro_x, gyro_y, gyro_z: log in 'deg/h'" in out and "made from 'pulse'" in out
    assert "Traceback" not in r.output and not (tmp_path / "nav").exists()
