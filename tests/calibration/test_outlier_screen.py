"""Issue 39: the outlier screen's running median, decimated above DECIMATE_FROM samples per
window: it flags injected spikes and nothing of a clean thermal drift, as the running median
does, and is the running median itself below."""

from __future__ import annotations

import numpy as np
import pytest

from rinscal.calibration.thermal.outliers import (
    DECIMATE_FROM,
    OutlierConfig,
    _decimated_median,
    _median_filter,
    outlier_mask,
)
from rinscal.errors import ConfigError

RATE_HZ = 100.0
N = 360_000  # one hour at 100 Hz: a 10 s window is 1001 samples, decimated by 15


def _warm_up(n=N, noise=1.0, seed=0):
    """A cold start: the output follows the sensor's warm-up, a fast and a slow exponential
    (deg/h; steepest at the start)."""
    t = np.arange(n) / RATE_HZ
    drift = 30.0 * (1 - np.exp(-t / 900.0)) + 5.0 * (1 - np.exp(-t / 60.0))
    return t, 12.0 + drift + np.random.default_rng(seed).normal(0.0, noise, n)


def _spiked(y, seed=1, count=60, size=25.0):
    rng = np.random.default_rng(seed)
    at = np.sort(rng.choice(np.arange(5, y.size - 5), count, replace=False))
    y = y.copy()
    y[at] += size * rng.choice([-1.0, 1.0], count)
    return y, at


@pytest.mark.parametrize("noise", [1.0, 0.0])
def test_a_clean_warm_up_is_not_flagged(noise) -> None:
    """A thermal drift with white noise, and without any (a steep start included: the
    interpolation of the decimated medians is allowed for). (Neither screen keeps a
    noiseless drift's turning point unflagged: a running median is flat there.)"""
    t, y = _warm_up(noise=noise)
    assert not outlier_mask(t, y, OutlierConfig()).any()
    assert not outlier_mask(t, y, OutlierConfig(kind="running")).any()


@pytest.mark.parametrize("noise", [1.0, 0.0])
def test_injected_spikes_are_flagged_and_nothing_else(noise) -> None:
    t, y = _warm_up(noise=noise)
    ys, at = _spiked(y)
    for kind in ("decimated", "running"):
        m = outlier_mask(t, ys, OutlierConfig(kind=kind))
        np.testing.assert_array_equal(np.flatnonzero(m), at, err_msg=kind)


def test_spikes_in_several_channels_quantised_and_missing_samples() -> None:
    """(n, m) at once, a quantised channel, NaN samples (never outliers)."""
    t, y = _warm_up()
    a, at_a = _spiked(y, seed=2)
    b, at_b = _spiked(np.round(_warm_up(noise=0.4, seed=3)[1]), seed=4, size=8.0)
    a[[100, 200_000]] = np.nan
    m = outlier_mask(t, np.column_stack([a, b]), OutlierConfig())
    np.testing.assert_array_equal(np.flatnonzero(m[:, 0]), at_a)
    np.testing.assert_array_equal(np.flatnonzero(m[:, 1]), at_b)


def test_the_baseline_is_the_running_median_below_the_decimation_window() -> None:
    """Fewer than DECIMATE_FROM samples per window (a 10 s window below 12.8 Hz): the
    running median itself, so the screen of the logs of before is unchanged to the bit."""
    rng = np.random.default_rng(5)
    y = rng.normal(size=20_000)
    for size in (5, 101, DECIMATE_FROM - 1):
        base, allow = _decimated_median(y, size)
        np.testing.assert_array_equal(base, _median_filter(y, size))
        assert allow == 0.0
    t = np.arange(20_000) * 1.0  # 1 Hz: an 11-sample window
    ys, _ = _spiked(y)
    np.testing.assert_array_equal(
        outlier_mask(t, ys, OutlierConfig()), outlier_mask(t, ys, OutlierConfig(kind="running"))
    )


def test_the_decimated_baseline_follows_the_running_median() -> None:
    """Noise σ = 1: the median of 67 samples strays from that of 1001 by about 0.15 σ, and the
    allowance is a small part of the 6-spread threshold; without noise, the baseline is the
    running median to within the allowance."""
    _, y = _warm_up()
    base, allow = _decimated_median(y, 1001)
    exact = _median_filter(y, 1001)
    assert np.sqrt(np.mean((base - exact) ** 2)) < 0.2
    assert np.median(allow) < 0.1 and allow.max() < 0.5
    _, y = _warm_up(noise=0.0)
    base, allow = _decimated_median(y, 1001)
    assert np.all(np.abs(base - _median_filter(y, 1001)) <= allow)
    assert np.abs(base - y).max() < 1e-3  # the drift itself (30 deg/h over the hour)


def test_the_kind_is_checked() -> None:
    with pytest.raises(ConfigError, match="kind"):
        OutlierConfig(kind="block")  # type: ignore[arg-type]
