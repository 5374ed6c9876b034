"""A log checked against an IMU calibration (``rinscal.calibration.imulog``): units that
differ are refused naming both, undeclared units are said, and rows outside the
calibration's temperature range are counted with the margin of :data:`RANGE_MARGIN_C`."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from rinscal.calibration.imulog import RANGE_MARGIN_C, CalibrationRangeTally, check_log_for_imu
from rinscal.errors import ConfigError
from rinscal.schema import CHANNELS

RAW = dict.fromkeys(CHANNELS, "pulse")


def test_a_log_in_other_units_than_the_calibrations_raw_ones_is_refused() -> None:
    meta = {"units": {c: ("deg/h" if c.startswith("gyro") else "ug") for c in CHANNELS}}
    with pytest.raises(ConfigError) as err:
        check_log_for_imu(RAW, None, meta, source="run.csv")
    msg = str(err.value)
    assert msg.startswith("run.csv: its units differ")
    assert "gyro_x, gyro_y, gyro_z: log in 'deg/h', the IMU calibration made from 'pulse'" in msg
    notes = check_log_for_imu(RAW, None, meta, refuse=False)  # told to ignore units
    assert notes == []


def test_undeclared_units_and_another_unit_are_warnings() -> None:
    meta = {"units": {"gyro_x": "pulse"}, "serial": "B"}
    notes = check_log_for_imu(RAW, {"serial": "A"}, meta)
    assert len(notes) == 2
    assert "declares no unit for gyro_y, gyro_z, accel_x, accel_y, accel_z" in notes[0]
    assert "(pulse)" in notes[0]
    assert "serial 'A' (the calibration) vs 'B' (the log)" in notes[1]


def test_rows_outside_the_range_are_counted_beyond_the_margin_only() -> None:
    tally = CalibrationRangeTally((15.0, 35.0))
    temps = [10.0, 15.0 - RANGE_MARGIN_C / 2, 25.0, 35.0 + RANGE_MARGIN_C / 2, 40.0, np.nan]
    log = pd.DataFrame({"time_s": np.arange(6.0), "temp_in": temps})
    tally.add(log)
    assert (tally.rows, tally.outside) == (5, 2)  # the NaN row is not read
    (note,) = tally.notes("run.csv")
    assert "40.0 % of the rows (2 of 5)" in note and "temp_in (gyro_x" in note
    assert "10.00 .. 40.00 °C" in note and "15.00 .. 35.00 °C" in note
    inside = CalibrationRangeTally((0.0, 50.0))
    inside.add(log)
    assert inside.notes("run.csv") == []
