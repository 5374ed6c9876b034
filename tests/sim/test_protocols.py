"""The paper's protocols: Table 3 set points, the ramp, the repeat start, reproducibility."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from rinscal.schema import CHANNELS, validate_log
from rinscal.sim.protocols import SOAK_SET_POINTS_C, protocol_runs, simulate_protocol


def test_soak_runs_are_table_3() -> None:
    runs = protocol_runs("soak")
    assert [r.name for r in runs] == [f"soak_{c:+03.0f}C" for c in (0, 7, 14, 21, 28, 35, 42)]
    assert all(r.duration_s == 3 * 3600 for r in runs)
    assert SOAK_SET_POINTS_C == (0.0, 7.0, 14.0, 21.0, 28.0, 35.0, 42.0)


def test_soak_log_is_canonical_and_starts_in_equilibrium() -> None:
    log, truth, meta = simulate_protocol(
        "soak", hours=1.0, rate_hz=1.0, seed=2, imu="navigation_grade"
    )
    validate_log(log, source="simulated")
    assert len(log) == len(truth) == 7 * 3600
    first = log.groupby("run", sort=False).head(1)
    set_points = first["chamber_temp"].to_numpy()
    np.testing.assert_allclose(first["temp_gyro_x"], set_points, atol=0.06)
    np.testing.assert_allclose(first["temp_out"], set_points, atol=0.03)
    last = log.groupby("run", sort=False).tail(1)
    assert np.all(last["temp_gyro_x"].to_numpy() - set_points > 5.0)  # power-on heating
    assert meta["units"]["gyro_x"] == "deg/h" and meta["units"]["accel_z"] == "ug"
    assert set(meta["turn_on_offset"]) == set(log["run"])


def test_ramp_follows_the_chamber_at_0_2_degrees_per_minute() -> None:
    log, _, _ = simulate_protocol("ramp", rate_hz=0.2, seed=0, imu="navigation_grade")
    assert log["time_s"].iloc[-1] == pytest.approx(52 / 0.2 * 60 + 1800, abs=5.0)
    ch = log["chamber_temp"].to_numpy()
    assert ch[0] == pytest.approx(-2.0 + 0.2 * 5 / 60) and ch[-1] == pytest.approx(50.0)
    # the housing (a 2.5 h thermal mass) lags, but its rate climbs towards the ramp's
    end = 52 / 0.2 * 60
    slopes = []
    for a, b in ((3600.0, 7200.0), (end - 3600.0, end)):
        sel = (log["time_s"] > a) & (log["time_s"] < b)
        slopes.append(np.polyfit(log.loc[sel, "time_s"] / 60.0, log.loc[sel, "temp_out"], 1)[0])
    assert 0.1 < slopes[0] < slopes[1] < 0.2
    assert slopes[1] == pytest.approx(0.2, rel=0.12)


def test_same_seed_same_log_other_seed_other_log() -> None:
    a, ta, _ = simulate_protocol("repeat", hours=0.2, rate_hz=5.0, seed=11, imu="navigation_grade")
    b, tb, _ = simulate_protocol("repeat", hours=0.2, rate_hz=5.0, seed=11, imu="navigation_grade")
    c, _, _ = simulate_protocol("repeat", hours=0.2, rate_hz=5.0, seed=12, imu="navigation_grade")
    pd.testing.assert_frame_equal(a, b)
    pd.testing.assert_frame_equal(ta, tb)
    assert not np.allclose(a[list(CHANNELS)], c[list(CHANNELS)])


def test_turn_on_offsets_differ_between_power_ons() -> None:
    """Repetition priming: every power-on has its own constant offset (Figure 1a)."""
    _, _, meta = simulate_protocol("soak", hours=0.05, rate_hz=1.0, seed=4, imu="navigation_grade")
    offs = np.array([[v[c] for c in CHANNELS] for v in meta["turn_on_offset"].values()])
    assert np.all(offs.std(axis=0) > 0)


def test_a_simulated_log_has_the_same_bits_whatever_the_thread_count() -> None:
    """Threaded BLAS matmuls once moved the last bits of a few rows per run with the thread
    count, and the BP network turned that into another reproduction on another machine."""
    from threadpoolctl import threadpool_limits

    from rinscal.sim.protocols import simulate_protocol

    runs = []
    for threads in (1, 2):
        with threadpool_limits(limits=threads, user_api="blas"):
            runs.append(
                simulate_protocol("soak", hours=0.5, rate_hz=1.0, seed=3, imu="navigation_grade")
            )
    for a, b in zip(runs[0][:2], runs[1][:2], strict=True):
        pd.testing.assert_frame_equal(a, b, check_exact=True)
