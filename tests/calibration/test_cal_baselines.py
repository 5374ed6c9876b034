"""PX4's and ArduPilot's own thermal fits: re-derived by hand, recovered, clamped, validated.

Each tool's procedure is re-derived here in plain steps (running median and moving average
by explicit loops, temperature bins by a loop over samples, then ``np.polyfit``) on a
synthetic two-run log with a known cubic, noise and outliers, and compared with
:mod:`rinscal.calibration.thermal.baselines`.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.base import clone

from rinscal.calibration.inference import n_inputs, predict_params, validate_params
from rinscal.calibration.thermal.baselines import ardupilot_fit, px4_fit
from rinscal.calibration.thermal.estimators import BASELINES, ArduPilotFit, PX4Fit

# true thermal error about 25 °C: [a0, a1, a2, a3] in output units / °C^k (deg/h-like);
# increasing on 5..45 °C (a1 + 2 a2 d + 3 a3 d² > 0 for |d| ≤ 20)
A = np.array([3.0, 0.05, -1.0e-3, 4.0e-5])
T0 = 25.0


def g(temp: np.ndarray) -> np.ndarray:
    """The true cubic [output units] at temperature ``temp`` [°C]."""
    d = np.asarray(temp) - T0
    return A[0] + A[1] * d + A[2] * d**2 + A[3] * d**3


def _x(temp: np.ndarray) -> np.ndarray:
    """Feature matrix ``T, Ṫ, ΔT`` (only ``T`` matters here)."""
    return np.column_stack([temp, np.zeros_like(temp), np.zeros_like(temp)])


@pytest.fixture(scope="module")
def noisy_log() -> dict[str, np.ndarray]:
    """Two cold starts: 10 Hz for 900 s (5 → 45 °C), 25 Hz for 300 s (12 → 38 °C).

    Output: the cubic + white noise (0.02) + 1 % outliers of ±2 (vibration spikes).
    """
    rng = np.random.default_rng(7)
    t1 = np.arange(9000) * 0.1
    t2 = np.arange(7500) * 0.04
    temp1 = 5.0 + 40.0 * (1.0 - np.exp(-t1 / 250.0)) / (1.0 - np.exp(-900.0 / 250.0))
    temp2 = 38.0 - 26.0 * np.exp(-t2 / 80.0)
    temp = np.concatenate([temp1, temp2]) + rng.normal(0.0, 0.01, 16500)
    y = g(temp) + rng.normal(0.0, 0.02, temp.size)
    spikes = rng.random(temp.size) < 0.01
    y[spikes] += rng.choice([-2.0, 2.0], spikes.sum())
    return {
        "temp": temp,
        "y": y,
        "t": np.concatenate([t1, t2]),
        "groups": np.repeat([3, 8], [9000, 7500]),
    }


def _runs(groups: np.ndarray) -> list[slice]:
    out, start = [], 0
    for i in range(1, len(groups) + 1):
        if i == len(groups) or groups[i] != groups[i - 1]:
            out.append(slice(start, i))
            start = i
    return out


# ----------------------------------------------------------------------------- by hand


def hand_medfilt31(v: np.ndarray) -> np.ndarray:
    """``scipy.signal.medfilt(v, 31)`` by hand: zero-padded, centred, sorted middle value."""
    padded = [0.0] * 15 + [float(a) for a in v] + [0.0] * 15
    return np.array([sorted(padded[i : i + 31])[15] for i in range(len(v))])


def hand_bins(x: np.ndarray, y: np.ndarray, nb: int = 2000) -> tuple[np.ndarray, np.ndarray]:
    """Means per non-empty bin of 2000 equal temperature bins, by a loop over samples."""
    lo, hi = float(min(x)), float(max(x))
    width = (hi - lo) / nb
    sx, sy, cnt = [0.0] * nb, [0.0] * nb, [0] * nb
    for xi, yi in zip(x.tolist(), y.tolist(), strict=True):
        b = int((xi - lo) / width) if xi < hi else nb - 1
        sx[b] += xi
        sy[b] += yi
        cnt[b] += 1
    keep = [b for b in range(nb) if cnt[b] > 0]
    return np.array([sx[b] / cnt[b] for b in keep]), np.array([sy[b] / cnt[b] for b in keep])


def hand_px4(temp, y, groups, accel: bool) -> tuple[float, float, float, np.ndarray]:
    tmin, tmax = float(min(temp)), float(max(temp))
    tref = 0.5 * (tmin + tmax)
    yf = np.concatenate([hand_medfilt31(y[r]) for r in _runs(groups)])
    if accel:
        yf = yf - np.median(yf)
    xb, yb = hand_bins(temp - tref, yf)
    x3, x2, x1, x0 = np.polyfit(xb, yb, 3)
    return tref, tmin, tmax, np.array([x0, x1, x2, x3])


def hand_boxcar(v: list[float], w: int) -> list[float]:
    return [sum(v[i : i + w]) / w for i in range(len(v) - w + 1)]


def hand_ardupilot(temp, y, t, groups) -> tuple[float, float, np.ndarray, list[int]]:
    ts, ys, windows = [], [], []
    for r in _runs(groups):
        n = r.stop - r.start
        w = int(n / (t[r][-1] - t[r][0])) * 2
        windows.append(w)
        ts += hand_boxcar(temp[r].tolist(), w)
        ys += hand_boxcar(y[r].tolist(), w)
    c3, c2, c1, _ = np.polyfit(np.array(ts) - 35.0, np.array(ys), 3)
    tmin, tmax = min(ts), max(ts)
    d = np.clip(temp, tmin, tmax) - 35.0
    c0 = np.mean(y - (c1 * d + c2 * d**2 + c3 * d**3))
    return tmin, tmax, np.array([c0, c1, c2, c3]), windows


def _close(ours, ref) -> None:
    ours, ref = np.asarray(ours), np.asarray(ref)
    np.testing.assert_allclose(ours, ref, rtol=1e-8, atol=1e-12 * np.max(np.abs(ref)))


# ----------------------------------------------------------------------------- PX4


def test_px4_gyro_matches_the_scripts_procedure(noisy_log) -> None:
    d = noisy_log
    est = PX4Fit(sensor="gyro").fit(_x(d["temp"]), d["y"], groups=d["groups"])
    tref, tmin, tmax, coef = hand_px4(d["temp"], d["y"], d["groups"], accel=False)
    assert (est.t_min_, est.t_max_, est.t_ref_) == (tmin, tmax, tref)
    _close(est.coef_, coef)
    # the fit is the thermal error, outliers and noise filtered out: within 0.01 of it
    grid = np.linspace(tmin, tmax, 50)
    assert np.max(np.abs(est.predict(_x(grid)) - g(grid))) < 0.01


def test_px4_accelerometer_fits_the_output_minus_its_median_and_keeps_the_level(
    noisy_log,
) -> None:
    d = noisy_log
    level = 1.0e6  # an accelerometer's 1 g in µg
    y = level + d["y"]
    acc = PX4Fit(sensor="accel").fit(_x(d["temp"]), y, groups=d["groups"])
    gyro = PX4Fit(sensor="gyro").fit(_x(d["temp"]), y, groups=d["groups"])
    _, _, _, script = hand_px4(d["temp"], y, d["groups"], accel=True)
    med = np.median(np.concatenate([hand_medfilt31(y[r]) for r in _runs(d["groups"])]))
    # the script's coefficients: the cubic of the output less its median ...
    _close(acc.coef_[1:], script[1:])
    assert acc.coef_[0] - med == pytest.approx(script[0], abs=1e-6)
    assert abs(script[0]) < 1.0  # the script's X0 holds no 1 g
    # ... and the model keeps the level (binning and least squares are linear), so that
    # N − (f − r) with r = 1 g removes gravity once (issue 21, item 1)
    _close(acc.coef_, gyro.coef_)
    assert acc.coef_[0] == pytest.approx(level, rel=1e-5)


def test_px4_without_resampling_fits_every_filtered_sample(noisy_log) -> None:
    d = noisy_log
    p = px4_fit(d["temp"], d["y"], d["groups"], resample=False)
    yf = np.concatenate([hand_medfilt31(d["y"][r]) for r in _runs(d["groups"])])
    _close(p["coef"], np.polyfit(d["temp"] - p["t_ref"], yf, 3)[::-1])


def test_px4_recovers_a_noise_free_cubic_exactly() -> None:
    # thermometer quantised to 0.05 °C (> the 0.02 °C bin width: one temperature per bin),
    # output monotone in time with 400-sample holds at both ends of each run, so the zero-padded
    # running median is the identity and every bin mean lies on the cubic
    hold = np.full(400, 0.0)
    ramp1 = np.concatenate([hold + 5.0, np.linspace(5.0, 45.0, 4000), hold + 45.0])
    ramp2 = np.concatenate([hold + 40.0, np.linspace(40.0, 9.0, 3000), hold + 9.0])
    temp = np.round(np.concatenate([ramp1, ramp2]) / 0.05) * 0.05
    groups = np.repeat([0, 1], [ramp1.size, ramp2.size])
    est = PX4Fit().fit(_x(temp), g(temp), groups=groups)
    assert est.t_ref_ == pytest.approx(T0, abs=1e-12)
    np.testing.assert_allclose(est.coef_, A, rtol=1e-9, atol=1e-13)
    # accelerometer: the script fits the cubic less the median of the output; the model
    # adds the median back, so it is the same cubic
    acc = PX4Fit(sensor="accel").fit(_x(temp), g(temp), groups=groups)
    np.testing.assert_allclose(acc.coef_, A, rtol=1e-9, atol=1e-13)


# ----------------------------------------------------------------------------- ArduPilot


def test_ardupilot_matches_the_scripts_procedure(noisy_log) -> None:
    d = noisy_log
    est = ArduPilotFit().fit(_x(d["temp"]), d["y"], groups=d["groups"], t=d["t"])
    tmin, tmax, coef, windows = hand_ardupilot(d["temp"], d["y"], d["t"], d["groups"])
    assert windows == [20, 50]  # 2 s at 10 Hz and at 25 Hz, each run its own
    assert est.t_ref_ == 35.0
    assert est.t_min_ == pytest.approx(tmin, rel=1e-13)
    assert est.t_max_ == pytest.approx(tmax, rel=1e-13)
    _close(est.coef_, coef)
    # the constant is the training level: the compensated log has zero mean
    assert np.mean(d["y"] - est.predict(_x(d["temp"]))) == pytest.approx(0.0, abs=1e-12)
    # an accelerometer differs only in the constant ArduPilot drops
    acc = ArduPilotFit(sensor="accel").fit(_x(d["temp"]), d["y"], groups=d["groups"], t=d["t"])
    _close(acc.coef_, est.coef_)


def test_ardupilot_recovers_a_noise_free_cubic_up_to_the_boxcar_bias() -> None:
    # linear ramps at ±0.05 °C/s sampled at 10 Hz: the 2 s (20-sample) boxcar sees a uniform
    # spread of temperatures with variance σ² = (r dt)² (w² − 1) / 12, and for a cubic
    # mean(g) = g(T̄) + g''(T̄) σ² / 2 exactly: a3 and a2 unchanged, a1 → a1 + 3 a3 σ²
    r, dt, w = 0.05, 0.1, 20
    t = np.arange(8001) * dt
    temp = np.concatenate([5.0 + r * t, 45.0 - r * t])
    tt = np.concatenate([t, t])
    groups = np.repeat([0, 1], t.size)
    est = ArduPilotFit().fit(_x(temp), g(temp), groups=groups, t=tt)
    var = (r * dt) ** 2 * (w**2 - 1) / 12.0
    smoothed = np.polynomial.Polynomial(A) + np.polynomial.Polynomial(
        [A[2] * var, 3.0 * A[3] * var]
    )
    about35 = smoothed(np.polynomial.Polynomial([35.0 - T0, 1.0])).coef  # powers of T − 35
    np.testing.assert_allclose(est.coef_[1:], about35[1:], rtol=1e-9)
    # smoothing shaves half a window off each end of the range
    assert est.t_min_ == pytest.approx(5.0 + r * dt * (w - 1) / 2, abs=1e-9)
    assert est.t_max_ == pytest.approx(45.0 - r * dt * (w - 1) / 2, abs=1e-9)
    # held at fixed temperatures (one run per plateau: a window straddling a step would mix
    # two plateaus and fall off the cubic) the boxcar changes nothing: exact recovery
    steps = np.repeat(np.arange(5.0, 46.0, 5.0), 300)
    tt = np.tile(np.arange(300) * dt, 9)
    per_step = np.repeat(np.arange(9), 300)
    ref = np.polynomial.Polynomial(A)(np.polynomial.Polynomial([35.0 - T0, 1.0])).coef
    exact = ArduPilotFit().fit(_x(steps), g(steps), groups=per_step, t=tt)
    np.testing.assert_allclose(exact.coef_[1:], ref[1:], rtol=1e-9)
    assert exact.coef_[0] == pytest.approx(ref[0], rel=1e-9)


def test_ardupilot_needs_the_time() -> None:
    temp = np.linspace(5.0, 45.0, 500)
    with pytest.raises(ValueError, match="needs t"):
        ArduPilotFit().fit(_x(temp), g(temp))
    with pytest.raises(ValueError, match="pass t"):
        ardupilot_fit(temp, g(temp), None)
    with pytest.raises(ValueError, match="time must increase"):
        ArduPilotFit().fit(_x(temp), g(temp), t=np.zeros(500))


# ----------------------------------------------------------------------------- firmware


def test_both_clamp_to_the_calibrated_range_as_the_firmwares_do(noisy_log) -> None:
    d = noisy_log
    px4 = PX4Fit().fit(_x(d["temp"]), d["y"], groups=d["groups"])
    ap = ArduPilotFit().fit(_x(d["temp"]), d["y"], groups=d["groups"], t=d["t"])
    temps = np.array([-40.0, px4.t_min_ - 1.0, 20.0, px4.t_max_ + 0.5, 85.0])

    # PX4 calc_thermal_offsets_3D: d = clamp(T) − TREF, offset = X0 + X1 d + X2 d² + X3 d³
    x0, x1, x2, x3 = px4.coef_
    for temp in temps:
        tc = min(max(temp, px4.t_min_), px4.t_max_)
        dd = tc - px4.t_ref_
        offset = x0 + x1 * dd + x2 * dd**2 + x3 * dd**3
        assert px4.predict(_x(np.array([temp])))[0] == pytest.approx(offset, rel=1e-12)
    below, above = px4.predict(_x(np.array([-40.0, 85.0])))
    assert below == px4.predict(_x(np.array([px4.t_min_])))[0]
    assert above == px4.predict(_x(np.array([px4.t_max_])))[0]

    # ArduPilot correct_sensor: v −= P(clamp(T) − 35); v += P(clamp(T_cal) − 35), P without
    # constant: the same correction as our model's, up to the level at T_cal
    def poly_eval(tdiff: float) -> float:
        c1, c2, c3 = ap.coef_[1:]
        return (c1 + (c2 + c3 * tdiff) * tdiff) * tdiff

    def clamp(v: float) -> float:
        return min(max(v, ap.t_min_), ap.t_max_)

    t_cal = 22.0
    f_cal = ap.predict(_x(np.array([t_cal])))[0]
    for temp in temps:
        firmware = poly_eval(clamp(temp) - 35.0) - poly_eval(clamp(t_cal) - 35.0)
        ours = ap.predict(_x(np.array([temp])))[0] - f_cal
        assert ours == pytest.approx(firmware, rel=1e-12, abs=1e-12)


# ----------------------------------------------------------------------------- data handling


@pytest.mark.parametrize("method", ["px4", "ardupilot"])
def test_nan_rows_are_dropped_before_filtering(noisy_log, method) -> None:
    d = noisy_log
    y = d["y"].copy()
    gaps = np.zeros(y.size, dtype=bool)
    gaps[[0, 17, 4000, 8999, 9000, 12345, 16499]] = True
    y[gaps] = np.nan
    est = BASELINES[method]()
    a = clone(est).fit(_x(d["temp"]), y, groups=d["groups"], t=d["t"])
    keep = ~gaps
    b = clone(est).fit(_x(d["temp"][keep]), y[keep], groups=d["groups"][keep], t=d["t"][keep])
    assert a.params_ == b.params_


def test_bad_fit_inputs_are_refused(noisy_log) -> None:
    temp = np.linspace(5.0, 45.0, 600)
    t = np.arange(600) * 0.1
    with pytest.raises(ValueError, match="sensor must be"):
        PX4Fit(sensor="magnetometer").fit(_x(temp), g(temp))
    with pytest.raises(ValueError, match="contiguous"):
        PX4Fit().fit(_x(temp), g(temp), groups=np.tile([0, 1], 300))
    with pytest.raises(ValueError, match="temperature range is empty"):
        PX4Fit().fit(_x(np.full(600, 20.0)), g(temp))
    with pytest.raises(ValueError, match="at least 4 distinct"):
        ArduPilotFit().fit(_x(np.full(600, 20.0)), g(temp), t=t)
    with pytest.raises(ValueError, match="window_s"):
        ArduPilotFit(window_s=0).fit(_x(temp), g(temp), t=t)
    with pytest.raises(ValueError, match="no finite output"):
        PX4Fit().fit(_x(temp), np.full(600, np.nan))


# ----------------------------------------------------------------------------- parameters


def test_fitted_params_are_valid_and_predict_through_the_numpy_evaluator(noisy_log) -> None:
    d = noisy_log
    for name, cls in BASELINES.items():
        est = cls().fit(_x(d["temp"]), d["y"], groups=d["groups"], t=d["t"])
        p = est.export_params()
        validate_params(p)
        assert p["method"] == name == est.method
        assert n_inputs(p) == 1
        x = _x(np.linspace(0.0, 60.0, 61))
        np.testing.assert_array_equal(est.predict(x), predict_params(p, x[:, :1]))


GOOD = {"method": "px4", "t_ref": 25.0, "t_min": 5.0, "t_max": 45.0, "coef": [1.0, 2, 3, 4]}


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"coef": [1.0, 2.0, 3.0]}, "'coef' has shape"),
        ({"coef": [1.0, 2.0, 3.0, 4.0, 5.0]}, "'coef' has shape"),
        ({"coef": [1.0, float("nan"), 3.0, 4.0]}, "non-finite"),
        ({"t_min": 50.0}, "'t_min' .* is above 't_max'"),
        ({"t_max": float("inf")}, "'t_max' must be a finite number"),
        ({"t_ref": True}, "'t_ref' must be a finite number"),
        ({"t_ref": "25"}, "'t_ref' must be a finite number"),
        ({"method": "ardupilot"}, "must be 35.0"),
        ({"orders": [3]}, "unexpected key"),
    ],
)
def test_param_validation_names_the_problem(change, message) -> None:
    with pytest.raises(ValueError, match=message):
        validate_params({**GOOD, **change})


def test_param_validation_missing_key_and_accepts_the_good_forms() -> None:
    bad = dict(GOOD)
    del bad["t_min"]
    with pytest.raises(ValueError, match="missing key"):
        validate_params(bad)
    validate_params(GOOD)
    validate_params({**GOOD, "method": "ardupilot", "t_ref": 35.0})
    # evaluation: T clamped to [t_min, t_max], powers of (T − t_ref)
    x = np.array([[0.0], [25.0], [26.0], [99.0]])
    np.testing.assert_allclose(
        predict_params(GOOD, x), [1 - 40 + 1200 - 32000, 1, 10, 1 + 40 + 1200 + 32000]
    )


def test_distinct_values_are_counted_as_numpy_unique_counts_them() -> None:
    """The cubic fits refuse fewer than 4 distinct temperatures: the count without a sort
    says what ``np.unique`` says, NaNs (one value), signed zeros and infinities included."""
    from rinscal.calibration.thermal.baselines import _distinct_at_least

    rng = np.random.default_rng(0)
    for _ in range(2000):
        x = rng.choice([0.0, -0.0, 1.0, 2.0, np.nan, np.inf, -np.inf, 3.5], size=rng.integers(12))
        for m in range(1, 6):
            assert _distinct_at_least(x, m) == (np.unique(x).size >= m)


def test_the_moving_average_at_chosen_windows_is_the_whole_run_s_to_the_last_bit() -> None:
    """``auto`` keeps ArduPilot's moving average at every k-th row only
    (:func:`rinscal.calibration.thermal._moving_average.window_means_at`): the same numbers
    as :func:`rinscal.calibration.thermal.baselines.moving_average` of the whole run, bit for
    bit, on a column of a wider array (strided) too."""
    from rinscal.calibration.thermal._moving_average import window_means_at
    from rinscal.calibration.thermal.baselines import moving_average

    rng = np.random.default_rng(3)
    for _ in range(200):
        n = int(rng.integers(1, 3000))
        w = int(rng.integers(1, n + 1))
        wide = 20 + np.cumsum(rng.normal(0, 0.05, (n, 3)), axis=0)  # a drifting temperature
        x = wide[:, 1]  # strided
        step, first = int(rng.integers(1, 12)), int(rng.integers(0, 12))
        starts = np.arange(first, n - w + 1, step)
        out = 1e3 + np.cumsum(rng.normal(0, 1.0, n))  # an output, summed in the same pass
        want = moving_average(x, w)[starts], moving_average(out, w)[starts]
        for series in (x, np.ascontiguousarray(x)):
            got = window_means_at(series, out, w, starts)
            assert got[0].tobytes() == want[0].tobytes(), (n, w, step, first)
            assert got[1].tobytes() == want[1].tobytes(), (n, w, step, first)
    none = window_means_at(np.ones(5), np.ones(5), 3, np.zeros(0, dtype=np.int64))
    assert none[0].size == none[1].size == 0


def test_the_median_at_kept_rows_is_the_whole_run_s_filter() -> None:
    """``auto``'s PX4 median at every k-th row (whole-run filter or the rows' windows alone)
    is :func:`rinscal.calibration.thermal.baselines.px4_median_filter` at those rows."""
    from rinscal.calibration.thermal.baselines import px4_median_filter
    from rinscal.calibration.thermal.runs import _median_at

    rng = np.random.default_rng(4)
    for n in (1, 7, 40, 5000):
        y = rng.normal(3.0, 1.0, n).round(1)  # ties, as a quantised output has
        for step in (1, 2, 3, 8):
            for first in {0, min(step - 1, n - 1)}:
                keep = np.arange(first, n, step)
                assert np.array_equal(_median_at(y, keep), px4_median_filter(y)[keep])


def test_the_median_network_selects_the_16th_of_32_values() -> None:
    """The kernel's compare-exchanges are those :func:`median_network` builds (read from its
    source), for PX4's 31-sample window, and applied to 31 values and +inf they put the
    median in position 15: checked here by applying them in Python to windows with ties,
    signed values and runs of equal values, against ``numpy.median``."""
    import inspect
    import re

    from rinscal.calibration.thermal import _running_median
    from rinscal.calibration.thermal.baselines import PX4_MEDIAN_KERNEL

    assert PX4_MEDIAN_KERNEL == 31  # the kernel is written out for this window
    net = _running_median.median_network()
    src = inspect.getsource(_running_median._medians)
    written = [(int(a), int(b)) for a, b in re.findall(r"v(\d+), v(\d+) = min", src)]
    assert written == net
    assert all(a < b < 31 for a, b in net)
    rng = np.random.default_rng(11)
    for _ in range(3000):
        ties = rng.random() < 0.5
        w = rng.choice([-2.0, -1.0, 0.0, 1.0, 2.5], 31) if ties else rng.normal(size=31)
        v = [*w.tolist(), np.inf]
        for a, b in net:
            v[a], v[b] = min(v[a], v[b]), max(v[a], v[b])
        assert v[15] == np.median(w)


@settings(max_examples=200, deadline=None)
@given(
    n=st.integers(1, 400),
    step=st.integers(1, 20),
    first=st.integers(0, 19),
    levels=st.sampled_from([0, 3, 1000]),
    seed=st.integers(0, 2**32 - 1),
)
def test_medians_at_chosen_rows_are_scipy_s_filter(
    n: int, step: int, first: int, levels: int, seed: int
) -> None:
    """:func:`medians_at` is PX4's filter (``scipy.ndimage.median_filter``, zeros beyond the
    ends) at any rows, bit for bit but for the sign of a zero (``+ 0.0`` makes ``-0.0``
    ``0.0``): short runs (a window wider than the run), the first and last 15 rows,
    quantised outputs with many ties and signed zeros."""
    from rinscal.calibration.thermal._running_median import medians_at
    from rinscal.calibration.thermal.baselines import px4_median_filter

    rng = np.random.default_rng(seed)
    y = rng.normal(0.0, 1.0, n)
    if levels:
        y = np.round(y * levels / 4) / (levels / 4)
    keep = np.arange(min(first, n - 1), n, step)
    got, want = medians_at(y, keep), px4_median_filter(y)[keep]
    assert (got + 0.0).tobytes() == (want + 0.0).tobytes()
