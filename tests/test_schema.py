"""Validation of the canonical calibration log (rinscal.schema)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rinscal.errors import LogError
from rinscal.schema import (
    ACCEL_CHANNELS,
    CHANNELS,
    GYRO_CHANNELS,
    TEMP_CHANNELS,
    check_finite,
    temp_column,
    temperature_column,
    validate_log,
)


def make_log(n: int = 5, runs: tuple[str, ...] = ("a", "b"), per_channel: bool = False):
    """A small valid log: ``n`` samples per run at 1 Hz, runs stacked."""
    frames = []
    for k, run in enumerate(runs):
        t = np.arange(n, dtype=float)
        d = {"time_s": t, "run": run}
        for j, ch in enumerate(CHANNELS):
            d[ch] = 10.0 * j + 0.1 * t + k
        if per_channel:
            for j, col in enumerate(TEMP_CHANNELS):
                d[col] = 20.0 + 0.01 * t + j
        else:
            d["temp_in"] = 20.0 + 0.01 * t
        d["temp_out"] = 18.0 + 0.01 * t
        frames.append(pd.DataFrame(d))
    return pd.concat(frames, ignore_index=True)


def test_channel_order_is_the_contract():
    assert CHANNELS == ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
    assert GYRO_CHANNELS + ACCEL_CHANNELS == CHANNELS
    assert temp_column("accel_y") == "temp_accel_y"
    with pytest.raises(ValueError, match="unknown channel"):
        temp_column("mag_x")


def test_valid_log_keeps_rows_order_and_values():
    df = make_log()
    df["extra"] = np.arange(len(df))  # unknown columns are kept
    out = validate_log(df, "mem.csv")
    assert list(out.columns) == list(df.columns)
    assert out.index.equals(df.index)
    for col in ("time_s", *CHANNELS, "temp_in", "temp_out"):
        assert out[col].dtype == np.float64
        np.testing.assert_array_equal(out[col].to_numpy(), df[col].to_numpy())
    assert out["run"].tolist() == df["run"].tolist()
    np.testing.assert_array_equal(out["extra"].to_numpy(), df["extra"].to_numpy())


def test_numeric_strings_and_ints_become_float_runs_become_text():
    df = make_log(runs=("1", "2"))
    df["run"] = df["run"].astype(int)  # e.g. a CSV with run numbers
    df["gyro_x"] = df["gyro_x"].map(repr).astype(object)  # numbers stored as text
    df["time_s"] = df["time_s"].astype(np.int64)
    out = validate_log(df, "mem.csv")
    assert out["run"].tolist() == ["1"] * 5 + ["2"] * 5
    assert out["gyro_x"].dtype == np.float64
    np.testing.assert_array_equal(out["gyro_x"].to_numpy(), make_log()["gyro_x"].to_numpy())
    assert out["time_s"].dtype == np.float64


def test_nan_in_sensor_channel_is_kept_not_filled():
    df = make_log()
    df.loc[3, "accel_y"] = np.nan
    out = validate_log(df, "mem.csv")
    assert np.isnan(out.loc[3, "accel_y"])
    assert out["accel_y"].isna().sum() == 1
    assert len(out) == len(df)


def test_caller_frame_is_not_modified():
    df = make_log()
    df["gyro_x"] = df["gyro_x"].astype(object)
    validate_log(df, "mem.csv")
    assert df["gyro_x"].dtype == object


@pytest.mark.parametrize("column", ["time_s", "run", "accel_z"])
def test_missing_required_column_is_named(column):
    df = make_log().drop(columns=[column])
    with pytest.raises(LogError, match=rf"mem\.csv: missing required column\(s\) '{column}'"):
        validate_log(df, "mem.csv")


def test_missing_temperature_names_the_missing_per_channel_columns():
    df = make_log(per_channel=True).drop(columns=["temp_gyro_z", "temp_accel_x"])
    with pytest.raises(LogError) as info:
        validate_log(df, "mem.csv")
    msg = str(info.value)
    assert "mem.csv" in msg and "'temp_gyro_z'" in msg and "'temp_accel_x'" in msg
    assert "'temp_in'" in msg
    assert "'temp_gyro_x'" not in msg


def test_partial_per_channel_temperatures_fall_back_to_temp_in():
    df = make_log(per_channel=False)
    df["temp_gyro_x"] = df["temp_in"] + 1.0
    out = validate_log(df, "mem.csv")
    assert temperature_column(out, "gyro_x") == "temp_gyro_x"
    assert temperature_column(out, "accel_z") == "temp_in"
    full = make_log(per_channel=True)
    assert [temperature_column(full, c) for c in CHANNELS] == list(TEMP_CHANNELS)
    with pytest.raises(LogError, match="no inner temperature for gyro_y"):
        temperature_column(full.drop(columns=["temp_gyro_y"]), "gyro_y")


def test_non_numeric_value_names_column_row_and_value():
    df = make_log()
    df["accel_x"] = df["accel_x"].astype(object)
    df.loc[6, "accel_x"] = "12.3.4"
    with pytest.raises(LogError) as info:
        validate_log(df, "mem.csv")
    msg = str(info.value)
    assert "mem.csv" in msg and "'accel_x'" in msg
    assert "data row 7" in msg  # 0-based position 6 is the 7th data row
    assert "'12.3.4'" in msg and "non-numeric" in msg


def test_boolean_column_is_not_numeric():
    df = make_log()
    df["gyro_y"] = df["gyro_y"] > 10
    with pytest.raises(LogError, match="'gyro_y' holds true/false"):
        validate_log(df, "mem.csv")


@pytest.mark.parametrize(
    ("column", "value", "what"),
    [
        ("time_s", np.nan, "missing value"),
        ("time_s", np.inf, "value inf"),
        ("temp_in", np.nan, "missing value"),
        ("temp_out", -np.inf, "value -inf"),
        ("gyro_z", np.inf, "value inf"),  # NaN is a dropped sample, inf is not
    ],
)
def test_non_finite_time_or_temperature_is_refused(column, value, what):
    df = make_log()
    df.loc[8, column] = value
    with pytest.raises(LogError) as info:
        validate_log(df, "mem.csv")
    msg = str(info.value)
    assert f"'{column}'" in msg and "data row 9" in msg and what in msg


def test_time_not_increasing_within_a_run_names_both_rows():
    df = make_log()
    df.loc[7, "time_s"] = 1.0  # run b: 0, 1, 1 -> row 8 (1-based) repeats row 7
    with pytest.raises(LogError) as info:
        validate_log(df, "mem.csv")
    msg = str(info.value)
    assert "'time_s'" in msg and "data row 8" in msg and "data row 7" in msg
    assert "not strictly increasing" in msg and "'b'" in msg


def test_time_restarting_between_runs_is_fine_and_interleaved_runs_are_checked_per_run():
    df = make_log()
    validate_log(df, "mem.csv")  # time restarts at 0 for run b: allowed
    inter = df.iloc[[0, 5, 1, 6, 2, 7, 3, 8, 4, 9]].reset_index(drop=True)
    validate_log(inter, "mem.csv")  # interleaved, each run increasing: allowed
    inter.loc[6, "time_s"] = 0.5  # run a: 0, 1, 2, 0.5 -> data row 7 goes back
    with pytest.raises(LogError, match=r"data row 7: time not strictly increasing within run 'a'"):
        validate_log(inter, "mem.csv")


def test_run_with_a_single_sample_is_refused():
    df = make_log()
    lone = df.iloc[[0]].assign(run="lonely")
    df = pd.concat([df, lone], ignore_index=True)
    with pytest.raises(LogError) as info:
        validate_log(df, "mem.csv")
    msg = str(info.value)
    assert "'lonely'" in msg and "data row 11" in msg and "at least 2" in msg


def test_categorical_runs_are_checked_as_their_text() -> None:
    """A run column read from Parquet is a dictionary (categorical): its runs are found from
    the codes, as they are from the text. Names no row uses (a row group's dictionary holds
    the runs before and after) are no runs; categories alike as text are one run."""
    df = make_log()
    unused = df.assign(run=pd.Categorical(df["run"], categories=["z", "a", "b", "q"]))
    out = validate_log(unused, "mem.parquet")
    assert out["run"].tolist() == df["run"].tolist()
    inter = unused.iloc[[0, 5, 1, 6, 2, 7, 3, 8, 4, 9]].reset_index(drop=True)
    validate_log(inter, "mem.parquet")  # interleaved, each run increasing
    inter.loc[6, "time_s"] = 0.5
    with pytest.raises(LogError, match=r"data row 7: time not strictly increasing within run 'a'"):
        validate_log(inter, "mem.parquet")
    lone = unused.copy()
    lone["run"] = pd.Categorical(["a"] * 5 + ["b"] * 4 + ["c"], categories=["z", "c", "b", "a"])
    with pytest.raises(LogError, match=r"data row 10: run 'c' has 1 sample\(s\)"):
        validate_log(lone, "mem.parquet")
    alike = df.assign(run=pd.Categorical([1] * 5 + ["1"] * 5, categories=[1, "1"]))
    alike.loc[5:, "time_s"] += 5.0  # one run "1", time increasing through it
    assert validate_log(alike, "mem.parquet")["run"].tolist() == ["1"] * 10
    alike.loc[5, "time_s"] = 4.0  # run "1": 4 after 4
    with pytest.raises(LogError, match=r"data row 6: time not strictly increasing within run '1'"):
        validate_log(alike, "mem.parquet")


def test_empty_run_name_is_refused():
    df = make_log()
    df["run"] = df["run"].astype(object)
    df.loc[2, "run"] = None
    with pytest.raises(LogError, match=r"'run', data row 3: empty run name"):
        validate_log(df, "mem.csv")


def test_header_only_and_non_tables_are_refused():
    with pytest.raises(LogError, match=r"mem\.csv: no data rows"):
        validate_log(make_log().iloc[0:0], "mem.csv")
    with pytest.raises(LogError, match=r"mem\.csv: not a table: one column"):
        validate_log(pd.DataFrame({"x": [1, 2]}), "mem.csv")
    with pytest.raises(LogError, match="not a table"):
        validate_log([1, 2, 3], "mem.csv")  # type: ignore[arg-type]


def test_mapped_names_show_in_messages():
    df = make_log()
    df.loc[2, "temp_in"] = np.nan
    with pytest.raises(LogError, match=r"column 'temp_in' \(from 'imu\.temperature'\)"):
        validate_log(df, "x.tsv", names={"temp_in": "imu.temperature"})


def _check_finite_reference(x: np.ndarray, allow_nan: bool) -> str | None:
    """The refusal of check_finite written as it first was: every value looked at."""
    bad = np.isinf(x) if allow_nan else ~np.isfinite(x)
    if not bad.any():
        return None
    pos = int(np.argmax(bad))
    return "missing value" if np.isnan(x[pos]) else f"data row {pos + 1}: value {x[pos]}"


@settings(max_examples=300, deadline=None)
@given(
    values=st.lists(
        st.one_of(
            st.floats(allow_nan=False, allow_infinity=False),
            st.sampled_from([np.nan, np.inf, -np.inf, 1e308, -1e308]),
        ),
        max_size=40,
    ),
    allow_nan=st.booleans(),
)
def test_check_finite_refuses_exactly_what_a_value_by_value_look_refuses(
    values: list[float], allow_nan: bool
) -> None:
    """Its one-pass test (a finite sum; finite extremes beside NaN) lets through exactly the
    columns with no refused value (sums that overflow included) and names the same row."""
    x = np.array(values, dtype=float)
    want = _check_finite_reference(x, allow_nan)
    try:
        check_finite(x, "f.csv", "gyro_x", None, allow_nan, "why")
    except LogError as exc:
        assert want is not None, f"refused a column it should take: {exc}"
        assert want in str(exc)
    else:
        assert want is None, f"took a column with {want}"
