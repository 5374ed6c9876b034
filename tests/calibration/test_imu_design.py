"""Bad designs named by calibrate_imu: rank, motion, missing temperatures, mixed units; and
the segmentation (whole revolutions, settle time)."""

from __future__ import annotations

import numpy as np
import pytest

from rinscal.calibration.imu.segments import TABLE_COLUMNS, find_segments
from rinscal.calibration.imu.workflow import calibrate_imu
from rinscal.errors import DesignError, LogError
from tests.calibration._imu_synth import RATE_AXES, Design, make_log, paper_like_truth

TRUTH = paper_like_truth()
FAST = Design(dwell_s=12.0, turns=1)


def _log(points=(10.0, 30.0), design=FAST, **kw):
    return make_log(TRUTH, points, design=design, seed=7, **kw)


def test_segments_are_whole_turns_after_the_settle_time():
    log, _, _ = _log((10.0,))
    table = log[list(TABLE_COLUMNS)].to_numpy()
    split = find_segments("cal_+10C", log.time_s.to_numpy(), table, settle_s=3.0)
    static = [s for s in split.segments if s.kind == "static"]
    rate = [s for s in split.segments if s.kind == "rate"]
    assert len(static) == 19 and len(rate) == 12
    # 12 s dwell at 10 Hz less 3 s settle: 90 samples; a turn at 20 °/s is 180 samples, at
    # 100 °/s 36: the angle swept by the used samples is exactly one revolution
    assert {s.n for s in static} == {90}
    for s in rate:
        assert s.turns == 1
        assert abs(s.rate_dps) * s.n / 10.0 == pytest.approx(360.0)
        assert s.t_start_s - log.time_s[_first_row(log, s)] >= 3.0 - 1e-9
    assert split.slews == 0


def _first_row(log, seg):
    """Row of the first sample of the constant-rate group that holds the segment."""
    k = seg.start
    rate = log.table_outer_rate_dps + 1j * log.table_inner_rate_dps
    while k > 0 and rate[k - 1] == rate[k]:
        k -= 1
    return k


def test_rank_names_the_parameters_and_what_is_lacking():
    no_x = Design(dwell_s=12.0, turns=1, rate_axes=RATE_AXES[:2])
    log, meta, _ = _log(design=no_x)
    with pytest.raises(
        DesignError, match=r"gyro_sf_x, gyro_mis_yx, gyro_mis_zx need a rate test about x"
    ) as e:
        calibrate_imu(log, meta, settle_s=3.0)
    assert "run cal_+10C" in str(e.value)
    one = Design(dwell_s=12.0, turns=1, rates_dps=(50.0,))
    log, meta, _ = _log(design=one)
    with pytest.raises(
        DesignError,
        match=r"gyro_sf_asym_x and gyro_sf_quad_x need rate tests about x at two or more rates "
        r"of both signs \(the design has only one rate magnitude\)",
    ):
        calibrate_imu(log, meta, settle_s=3.0)
    res = calibrate_imu(log, meta, settle_s=3.0, nonlinear=False)  # the linear part is fine
    assert len(res.estimates) == 2 * 24
    # accelerometers: z up and down only cannot give x and y scale factors
    flat_pos = [(0, i) for i in (0, 90, 180, 270)] + [(180, 0), (180, 90)]
    flat = Design(dwell_s=12.0, turns=1, positions=flat_pos)
    log, meta, _ = _log(design=flat)
    with pytest.raises(DesignError, match=r"accel_bias_x, accel_sf_x.*not separable") as e:
        calibrate_imu(log, meta, settle_s=3.0)
    assert "accel_sf_x and accel_sf_quad_x need axis x up, down and horizontal" in str(e.value)


def test_motion_detected_names_run_position_angles_and_time():
    # the table creeps at 0.002 °/s (7.2 °/h) about the outer axis during position 7
    log, meta, _ = _log(creep=("cal_+30C", 7, 0.002))
    with pytest.raises(DesignError, match="motion detected") as e:
        calibrate_imu(log, meta, settle_s=3.0)
    msg = str(e.value)
    assert "run cal_+30C" in msg and "position 7 (outer 90°, inner 180°," in msg
    assert "position 6" not in msg and "cal_+10C" not in msg
    assert "gyro_y residual" in msg  # the outer axis is IMU y at inner 180°


def test_missing_and_differing_temperature_points():
    log, meta, _ = _log((10.0, 30.0, 50.0))
    meta2 = {**meta, "set_points_c": {**meta["set_points_c"], "cal_+70C": 70.0}}
    with pytest.raises(
        DesignError,
        match=r"set point\(s\) of the metadata with no rows in the log: 70.0 °C \(run cal_\+70C\)",
    ):
        calibrate_imu(log, meta2, settle_s=3.0)
    one = log[log.run == "cal_+10C"]
    meta1 = {**meta, "set_points_c": {"cal_+10C": 10.0}}
    with pytest.raises(DesignError, match="a temperature law needs at least two set points"):
        calibrate_imu(one, meta1, settle_s=3.0)
    assert len(calibrate_imu(one, meta1, settle_s=3.0, max_degree=0).estimates) == 33
    # run cal_+50C lost its position 5 (outer 90°, inner 0°)
    stat = (log.table_outer_rate_dps == 0) & (log.table_inner_rate_dps == 0)
    pos5 = (log.run == "cal_+50C") & stat & (log.table_outer_deg == 90) & (log.table_inner_deg == 0)
    with pytest.raises(DesignError, match=r"run cal_\+50C lacks position \(outer 90°, inner 0°\)"):
        calibrate_imu(log[~pos5].reset_index(drop=True), meta, settle_s=3.0)


def test_units_mixed_unknown_or_without_factor_are_named():
    log, meta, _ = _log((10.0, 30.0))
    mixed = {**meta, "units": {**meta["units"], "gyro_y": "deg/h"}}
    mixed["unit_to_si"] = {k: v for k, v in meta["unit_to_si"].items() if k != "gyro_y"}
    with pytest.raises(
        DesignError,
        match=r"mixed units in the gyro triad: gyro_x in pulse, gyro_y in deg/h, gyro_z in pulse",
    ):
        calibrate_imu(log, mixed, settle_s=3.0)
    unknown = {**meta, "units": {**meta["units"], "accel_z": "furlong"}}
    with pytest.raises(DesignError, match=r"accel_z.*'furlong'"):
        calibrate_imu(log, unknown, settle_s=3.0)
    bare = {**meta, "unit_to_si": {}}
    with pytest.raises(
        DesignError,
        match=r"gyro_x, gyro_y, gyro_z, accel_x, accel_y, accel_z are in pulse without a factor",
    ):
        calibrate_imu(log, bare, settle_s=3.0)
    with pytest.raises(LogError, match="table_inner_rate_dps"):
        calibrate_imu(log.drop(columns="table_inner_rate_dps"), meta)
    no_site = {k: v for k, v in meta.items() if k != "latitude_deg"}
    with pytest.raises(ValueError, match="latitude_deg"):
        calibrate_imu(log, no_site)
    assert np.isfinite(calibrate_imu(log, meta, settle_s=3.0).estimates.value).all()
