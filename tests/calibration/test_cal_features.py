"""Features: the windowed least-squares temperature rate, gradients, outlier masks."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from rinscal.calibration.thermal import features
from rinscal.calibration.thermal.features import (
    DerivativeConfig,
    MissingGradientWarning,
    OutlierConfig,
    build_features,
    channel_matrix,
    column_rates,
    log_columns,
    outlier_mask,
    set_points,
    temperature_rate,
)
from rinscal.calibration.thermal.rate import CausalSlope, causal_slope, centred_slope_run
from rinscal.errors import ConfigError
from rinscal.schema import CHANNELS
from tests.calibration._helpers import synthetic_log


def _brute_slope(t: np.ndarray, x: np.ndarray, window: float, kind: str) -> np.ndarray:
    out = np.zeros_like(x)
    for i in range(t.size):
        if kind == "causal":
            m = (t >= t[i] - window) & (t <= t[i])
        else:
            m = np.abs(t - t[i]) <= window / 2
        if m.sum() < 2:
            continue
        tt, xx = t[m], x[m]
        out[i] = np.sum((tt - tt.mean()) * (xx - xx.mean())) / np.sum((tt - tt.mean()) ** 2)
    return out


@pytest.mark.parametrize("kind", ["centred", "causal"])
def test_rate_is_the_least_squares_slope_on_irregular_noisy_samples(kind: str) -> None:
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.3, 1.7, 4000))
    x = 20 + 5 * np.sin(t / 400) + rng.normal(0, 0.01, t.size)
    got = temperature_rate(t, x, DerivativeConfig(45.0, kind))  # °C/min
    want = _brute_slope(t, x, 45.0, kind) * 60.0
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-11 * np.abs(want).max())


@pytest.mark.parametrize("kind", ["centred", "causal"])
def test_rate_of_a_ramp_is_exact(kind: str) -> None:
    # a chamber ramp of 0.2 °C/min (Section 5.2.1), irregular sampling
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.5, 1.5, 3000))
    temp = -2.0 + 0.2 * t / 60.0
    rate = temperature_rate(t, temp, DerivativeConfig(60.0, kind))
    np.testing.assert_allclose(rate[1:], 0.2, rtol=1e-9)
    assert rate[0] == 0.0 if kind == "causal" else abs(rate[0] - 0.2) < 1e-9


def test_causal_rate_is_the_centred_rate_half_a_window_later() -> None:
    # uniform sampling with W a multiple of dt: the same window, placed differently
    dt, w = 0.5, 30.0
    t = np.arange(1, 5001) * dt
    x = np.sin(t / 300.0)[:, None] + 0.001 * np.cos(t / 7.0)[:, None]
    lag = int(w / 2 / dt)
    causal = causal_slope(t, x, w)
    centred = centred_slope_run(t, x, w)
    np.testing.assert_allclose(causal[2 * lag :], centred[lag:-lag], rtol=1e-10, atol=1e-14)


def test_streaming_slope_is_bit_identical_to_batch() -> None:
    rng = np.random.default_rng(2)
    t = np.cumsum(rng.uniform(0.2, 2.0, 1500))
    x = np.column_stack([np.cumsum(rng.normal(size=t.size)), np.sin(t)])
    batch = causal_slope(t, x, 25.0)
    stream = CausalSlope(25.0, 2, capacity=2)  # forces the ring to grow
    one_by_one = np.vstack([stream.update(t[i : i + 1], x[i : i + 1]) for i in range(t.size)])
    np.testing.assert_array_equal(one_by_one, batch)
    with pytest.raises(ValueError, match="strictly increasing"):
        stream.update(t[-1:], x[-1:])


def test_rate_never_crosses_a_run_boundary() -> None:
    rng = np.random.default_rng(3)
    log = synthetic_log(rng, runs=2, n=300)
    # a jump of 30 °C between the runs would spoil the rate near the boundary if mixed
    log.loc[log["run"] == "run1", [f"temp_{c}" for c in CHANNELS]] += 30.0
    feats = build_features(log, DerivativeConfig(60.0))
    for k, run in enumerate(["run0", "run1"]):
        sub = log[log["run"] == run]
        alone = temperature_rate(
            sub["time_s"].to_numpy(), sub["temp_accel_x"].to_numpy(), DerivativeConfig(60.0)
        )
        np.testing.assert_array_equal(feats.rate[feats.run_codes == k, 3], alone)


def test_interleaved_runs_are_processed_per_run() -> None:
    rng = np.random.default_rng(4)
    log = synthetic_log(rng, runs=2, n=200)
    order = np.argsort(np.r_[np.arange(200) * 2, np.arange(200) * 2 + 1], kind="stable")
    mixed = log.iloc[order].reset_index(drop=True)
    a = build_features(log)
    b = build_features(mixed)
    np.testing.assert_array_equal(b.rate, a.rate[order])
    np.testing.assert_array_equal(b.grad, a.grad[order])


def test_gradient_and_missing_outer_temperature() -> None:
    rng = np.random.default_rng(5)
    log = synthetic_log(rng)
    f = build_features(log)
    np.testing.assert_array_equal(f.grad[:, 2], log["temp_gyro_z"] - log["temp_out"])
    assert f.matrix("gyro_z").shape == (len(log), 3)
    with pytest.warns(MissingGradientWarning, match="temp_out"):
        g = build_features(log.drop(columns="temp_out"))
    assert g.grad is None and g.matrix(0).shape[1] == 2
    np.testing.assert_array_equal(g.rate, f.rate)


@pytest.mark.parametrize("gradient", [True, False])
def test_one_channel_s_features_are_those_of_all_channels(gradient: bool) -> None:
    """A fit builds one channel at a time: its inputs are one block, handed out as the
    feature matrix without a copy (read-only), the same numbers as built with every channel."""
    rng = np.random.default_rng(8)
    log = synthetic_log(rng)
    if not gradient:
        log = log.drop(columns="temp_out")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MissingGradientWarning)
        every = build_features(log)
        for j, c in enumerate(CHANNELS):
            one = build_features(log, channels=(c,))
            x = one.matrix(0)
            assert x.shape == (len(log), 3 if gradient else 2) and not x.flags.writeable
            assert np.shares_memory(x, one.temp) and np.shares_memory(x, one.rate)
            np.testing.assert_array_equal(x, every.matrix(j))
            np.testing.assert_array_equal(one.output[:, 0], every.output[:, j])
            np.testing.assert_array_equal(one.inlier[:, 0], every.inlier[:, j])
            np.testing.assert_array_equal(one.usable(0), every.usable(j))


@pytest.mark.parametrize("kind", ["centred", "causal"])
@pytest.mark.parametrize("layout", ["runs", "interleaved", "temp_in", "no temp_out"])
@pytest.mark.parametrize(("n_jobs", "block"), [(1, None), (2, None), (2, 1)])
def test_channel_inputs_from_the_rates_of_every_column_are_the_feature_matrix(
    kind: str, layout: str, n_jobs: int, block: int | None, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Compensation finds the rate of every temperature column in a few passes of the
    kernel (column_rates: groups of columns, on threads) and builds each channel's inputs
    from it: bit for bit the matrix of that channel's own features."""
    rng = np.random.default_rng(9)
    log = synthetic_log(rng, runs=3, n=300)
    if layout == "interleaved":
        order = np.argsort(np.r_[np.arange(600) * 2, np.arange(600, 900)], kind="stable")
        log = log.iloc[order].reset_index(drop=True)
    elif layout == "temp_in":
        log = log.drop(columns=[f"temp_{c}" for c in CHANNELS]).assign(temp_in=log["temp_gyro_y"])
    elif layout == "no temp_out":
        log = log.drop(columns="temp_out")
    grad = layout != "no temp_out"
    deriv = DerivativeConfig(60.0, kind)  # type: ignore[arg-type]
    cols = log_columns(log, CHANNELS)
    names = list(dict.fromkeys(cols.temp_column[c] for c in CHANNELS))
    if block is not None:  # blocks of one column: a group per column
        monkeypatch.setattr(features, "RATE_BLOCK_BYTES", block)
    rates = column_rates(cols, deriv, names, n_jobs)
    assert [r.shape for r in rates] == [(len(log),)] * len(names)
    off = OutlierConfig(enabled=False)
    for c in CHANNELS:
        x = channel_matrix(cols, c, rates[names.index(cols.temp_column[c])], grad)
        own = build_features(log, deriv, off, (c,), use_gradient=grad).matrix(0)
        assert x.shape == own.shape and x.flags.f_contiguous
        assert x.tobytes(order="F") == own.tobytes(order="F")


def test_shared_inner_temperature() -> None:
    rng = np.random.default_rng(6)
    log = synthetic_log(rng)
    shared = log.drop(columns=[f"temp_{c}" for c in CHANNELS]).assign(temp_in=log["temp_accel_x"])
    f = build_features(shared)
    for j in range(6):
        np.testing.assert_array_equal(f.temp[:, j], log["temp_accel_x"])
        np.testing.assert_array_equal(f.rate[:, j], f.rate[:, 0])


def test_outliers_are_masked_counted_and_never_dropped() -> None:
    rng = np.random.default_rng(7)
    log = synthetic_log(rng, runs=2, n=2000)
    for c in CHANNELS:
        log[c] = 100.0 + 0.01 * log["time_s"] + rng.normal(0, 1.0, len(log))
    spikes = {"run0": [100, 900, 1500], "run1": [2500, 3100]}
    for rows in spikes.values():
        log.loc[rows, "accel_y"] += 40.0  # torque-motor vibration, 40 sigma
    log.loc[[50, 2050], "gyro_x"] = np.nan  # dropped samples
    before = log.copy()
    f = build_features(log, outliers=OutlierConfig(window_s=20.0, threshold=6.0))
    pd.testing.assert_frame_equal(log, before)  # the user's data are untouched
    rep = f.report.to_frame().set_index(["run", "channel"])
    assert rep.loc[("run0", "accel_y"), "removed"] == 3
    assert rep.loc[("run1", "accel_y"), "removed"] == 2
    assert rep.loc[("run0", "gyro_x"), "missing"] == 1
    assert f.report.total("accel_y") == 5
    masked = np.flatnonzero(~f.inlier[:, 3 + 1])
    np.testing.assert_array_equal(masked, sorted(spikes["run0"] + spikes["run1"]))
    assert not f.inlier[50, 0] and not f.inlier[2050, 0]
    # Gaussian noise alone: 6 robust sigmas almost never flag a sample
    assert f.report.removed[:, [1, 2, 3, 5]].sum() <= 2


def test_outlier_mask_handles_quantised_output() -> None:
    t = np.arange(500.0)
    y = np.round(np.random.default_rng(8).normal(0, 0.3, 500))  # mostly 0, MAD = 0
    y[250] = 25.0
    m = outlier_mask(t, y, OutlierConfig(window_s=21.0))
    assert m[250] and m.sum() == 1


def test_set_points_are_the_chamber_temperatures_of_the_runs(soak_small) -> None:
    log, _, _ = soak_small
    np.testing.assert_array_equal(set_points(log), [0, 7, 14, 21, 28, 35, 42])
    assert set_points(log.drop(columns="chamber_temp")) is None


def test_configs_refuse_bad_values() -> None:
    with pytest.raises(ConfigError, match="window_s"):
        DerivativeConfig(0.0)
    with pytest.raises(ConfigError, match="kind"):
        DerivativeConfig(60.0, "forward")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="threshold"):
        OutlierConfig(threshold=-1)


def test_simulated_rate_matches_the_true_sensor_rate(soak_small) -> None:
    # the simulator's sensor temperature is smooth; quantised to 0.01 °C in the log
    log, _, _ = soak_small
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        f = build_features(log, DerivativeConfig(120.0))
    # during the first minutes of each cold start the unit heats up: positive rates
    first = np.array([np.argmax(f.run_codes == k) for k in range(7)])
    assert np.all(f.rate[first + 150, 3] > 0.01)
    # centred slope of T itself: compare with a finite difference over the same window
    r = f.run_codes == 3
    t, temp = f.time_s[r], f.temp[r, 3]
    i = 900
    j = np.searchsorted(t, [t[i] - 60, t[i] + 60])
    approx = (temp[j[1]] - temp[j[0]]) / (t[j[1]] - t[j[0]]) * 60
    assert abs(f.rate[r, 3][i] - approx) < 0.02


@pytest.mark.parametrize(("n", "k"), [(9, 7), (50, 11), (700, 5), (4001, 101)])
def test_short_running_median_equals_scipys(n, k) -> None:
    # the numpy path (short logs: no scipy import) gives scipy's values exactly, ties included
    from scipy.ndimage import median_filter

    from rinscal.calibration.thermal.outliers import _median_filter

    rng = np.random.default_rng(n)
    y = rng.normal(size=n)
    y[::3] = np.round(y[::3])
    assert np.array_equal(_median_filter(y, k), median_filter(y, size=k, mode="nearest"))
