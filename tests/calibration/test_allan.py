"""Allan deviation and IEEE Std 952 noise parameters (rinscal.calibration.allan).

Expected values come from the textbook processes, not from the code under test:

* white rate noise of standard deviation σ at τ0: ``σ(τ) = σ √(τ0/τ)`` exactly (the mean of
  m independent samples), so the ARW is ``N = σ √τ0``;
* a rate random walk with steps ``K √τ0``: ``σ²(τ) = K² τ/3`` for ``m ≫ 1`` and exactly
  ``K² τ0/2`` at ``m = 1`` (half the variance of one step);
* both together: ``σ²(τ) = N²/τ + K² τ/3``, a bowl with its bottom ``σ² = 2NK/√3`` at
  ``τ* = √3 N/K``;
* flicker (1/f) rate noise of one-sided PSD ``B²/(π f)`` (IEEE 952's two-sided
  ``B²/(2π f)``): a flat floor ``σ = 0.664 B``.

The overlapping Allan variance itself is checked against its definition (differences of
adjacent cluster means) written out here in numpy, and against ``allantools.oadev`` (the
test extra's oracle; the package computes it in numpy and does not need allantools).
"""

from __future__ import annotations

import io
import math
import sys

import allantools
import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

from rinscal.calibration.allan import (
    BIAS_INSTABILITY_FACTOR,
    AllanCurve,
    allan_deviation,
    allan_deviations,
    noise_parameters,
)
from rinscal.report.allan_plot import allan_figure

FS = 100.0  # [Hz]
TAU0 = 1.0 / FS  # [s]


def oavar_reference(y: np.ndarray, m: int) -> tuple[float, int]:
    """Overlapping Allan variance at τ = m τ0 from cluster means, and its number of pairs."""
    c = np.concatenate(([0.0], np.cumsum(y - y.mean())))
    means = (c[m:] - c[:-m]) / m  # every window of m samples
    d = means[m:] - means[:-m]  # adjacent, non-overlapping windows
    return 0.5 * float(np.mean(d**2)), d.size


def loglog_slope(curve: AllanCurve, keep: np.ndarray) -> float:
    return float(np.polyfit(np.log(curve.tau_s[keep]), np.log(curve.adev[keep]), 1)[0])


def readable(curve: AllanCurve, n: int) -> np.ndarray:
    """Points with ≥ 51 independent clusters (relative 1σ ≤ 1/√(2·50) = 10 %)."""
    return np.round(curve.tau_s * FS) <= n / 51


def flicker(rng: np.random.Generator, b: float, n: int) -> np.ndarray:
    """Rate noise of one-sided PSD B²/(π f) down to 1/(n τ0), shaped in the frequency domain."""
    f = np.fft.rfftfreq(n, TAU0)
    psd = np.zeros_like(f)
    psd[1:] = b**2 / (np.pi * f[1:])
    amp = np.sqrt(psd * FS * n / 4.0)  # irfft of amp·(a + ib) has the variance ∫ psd df
    return np.fft.irfft(amp * (rng.normal(size=f.size) + 1j * rng.normal(size=f.size)), n)


# ----------------------------------------------------------------------------- definition


def test_overlapping_allan_variance_matches_its_definition() -> None:
    rng = np.random.default_rng(0)
    n = 5000
    y = 40.0 + rng.normal(0, 3.0, n) + np.cumsum(rng.normal(0, 0.05, n))  # deg/h
    c = allan_deviation(y, FS)
    m = np.round(c.tau_s * FS).astype(int)
    assert list(m) == [2**k for k in range(12)]  # octaves up to (n − 1)/2 = 2499
    for j, mj in enumerate(m):
        avar, pairs = oavar_reference(y, int(mj))
        assert c.adev[j] == pytest.approx(math.sqrt(avar), rel=1e-9)
        assert c.n_pairs[j] == pairs == n - 2 * mj + 1
        k = n // mj  # independent clusters (IEEE 952)
        assert c.adev_err[j] == pytest.approx(c.adev[j] / math.sqrt(2 * (k - 1)), rel=1e-12)

    dec = allan_deviation(y, FS, taus="decade")
    assert list(np.round(dec.tau_s * FS)) == [1, 2, 4, 10, 20, 40, 100, 200, 400, 1000, 2000]
    given = allan_deviation(y, FS, taus=[0.05, 0.3, 0.3, 0.1])
    assert given.tau_s == pytest.approx([0.05, 0.1, 0.3])
    assert given.adev[2] == pytest.approx(math.sqrt(oavar_reference(y, 30)[0]), rel=1e-9)
    assert len(allan_deviation(y[:50], FS, taus="all")) == 24


@pytest.mark.parametrize("n", [1000, 4097, 30011])
@pytest.mark.parametrize("taus", ["octave", "decade", "all-short", "given"])
def test_agrees_with_allantools_oadev(n: int, taus: str) -> None:
    rng = np.random.default_rng(n)
    y = 1.0e3 + rng.normal(0.0, 2.0, n) + np.cumsum(rng.normal(0.0, 0.1, n))  # µg
    rate = 400.0
    if taus == "all-short":
        y, spec = y[:300], "all"
    elif taus == "given":
        spec = np.array([0.0025, 0.0125, 0.1, 0.9, (n // 2 - 1) / rate])
    else:
        spec = taus
    c = allan_deviation(y, rate, taus=spec)
    tau, dev, _, ns = allantools.oadev(y, rate=rate, data_type="freq", taus=c.tau_s)
    np.testing.assert_allclose(tau, c.tau_s, rtol=1e-15)
    np.testing.assert_allclose(c.adev, dev, rtol=1e-12, atol=0.0)
    np.testing.assert_array_equal(c.n_pairs, ns)


def test_needs_no_allantools_at_run_time(monkeypatch: pytest.MonkeyPatch) -> None:
    """allantools is the test oracle only: ``pip install rinscal`` does not bring it."""
    y = np.random.default_rng(12).normal(0.0, 1.0, 2000)
    expected = allan_deviation(y, FS).adev
    monkeypatch.setitem(sys.modules, "allantools", None)  # `import allantools` now fails
    np.testing.assert_array_equal(allan_deviation(y, FS).adev, expected)
    assert allan_deviations({"gyro_x": y}, FS)["gyro_x"].adev[0] == expected[0]


def test_curve_is_frozen_and_read_only() -> None:
    c = allan_deviation(np.random.default_rng(1).normal(size=100), FS)
    with pytest.raises(AttributeError):
        c.adev = c.adev  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        c.adev[0] = 0.0
    with pytest.raises(ValueError, match="increasing"):
        AllanCurve(tau_s=[2.0, 1.0], adev=[1.0, 1.0], adev_err=[0.1, 0.1], n_pairs=[5, 5])


# -------------------------------------------------------------------------------- physics


def test_white_noise_slope_minus_half_and_angle_random_walk() -> None:
    """A gyro with ARW 0.005 deg/√h: σ = 0.005·60/√τ0 deg/h per sample at 100 Hz."""
    arw_deg_rt_h = 0.005
    sigma = arw_deg_rt_h * 60.0 / math.sqrt(TAU0)  # 3.0 deg/h
    n = 2**18
    y = np.random.default_rng(2).normal(0.0, sigma, n)
    c = allan_deviation(y, FS)
    keep = readable(c, n)
    # relative 1σ ≤ 10 % per point over 13 octaves: the fitted slope is good to ~±0.01
    assert loglog_slope(c, keep) == pytest.approx(-0.5, abs=0.02)
    # σ(τ0) from n − 1 pairs: 1σ = 1/√(2(n − 1)) = 0.14 %
    assert c.adev[0] == pytest.approx(sigma, rel=0.05)
    p = noise_parameters(c)
    assert p.n == pytest.approx(sigma * math.sqrt(TAU0), rel=0.02)  # deg/h·√s
    assert p.n / 60.0 == pytest.approx(arw_deg_rt_h, rel=0.02)  # deg/√h
    assert p.n_tau_s is not None and p.n_tau_s[0] == pytest.approx(TAU0)
    assert p.b is None and p.b_tau_s is None
    assert p.k is None and p.k_tau_s is None


def test_random_walk_slope_plus_half_and_rate_random_walk() -> None:
    k_true = 0.05  # deg/h/√s
    n = 2**18
    y = np.cumsum(np.random.default_rng(3).normal(0.0, k_true * math.sqrt(TAU0), n))
    c = allan_deviation(y, FS)
    # exactly half the step variance at τ0 (1σ of the estimate 0.14 %)
    assert c.adev[0] ** 2 == pytest.approx(k_true**2 * TAU0 / 2.0, rel=0.02)
    keep = readable(c, n) & (c.tau_s >= 8 * TAU0)  # K²τ/3 holds to < 0.8 % from m = 8
    assert loglog_slope(c, keep) == pytest.approx(0.5, abs=0.03)
    p = noise_parameters(c)
    # The line is fitted over m = 4 … n/51; at τ = 3 s (m = 300) alone the relative 1σ is
    # 1/√(2(n/300 − 1)) = 2.4 %, and m = 4 reads 1.6 % high (K²τ/3 · (1 + 1/2m²)):
    # 10 % is a margin of about 4σ.
    assert p.k == pytest.approx(k_true, rel=0.10)
    assert p.k_tau_s is not None and p.k_tau_s[0] <= 3.0 <= p.k_tau_s[1]
    assert p.n is None and p.b is None


def test_textbook_curves_point_by_point() -> None:
    """White rate noise of density N: σ(τ) = N/√τ; a rate random walk K: σ(τ) = K √(τ/3).

    Each readable point (≥ 51 clusters) within 4 of its own 1σ (``adev_err``); the random
    walk from m = 8, where the exact σ² = K²τ/3 (1 + 1/(2m²)) is within 0.8 % of K²τ/3.
    """
    n = 2**18
    rng = np.random.default_rng(13)
    n_true = 0.02  # deg/h·√s
    white = allan_deviation(rng.normal(0.0, n_true / math.sqrt(TAU0), n), FS)
    keep = readable(white, n)
    expected = n_true / np.sqrt(white.tau_s[keep])
    assert np.all(np.abs(white.adev[keep] - expected) <= 4.0 * white.adev_err[keep])
    assert keep.sum() >= 12

    k_true = 0.05  # deg/h/√s
    walk = allan_deviation(np.cumsum(rng.normal(0.0, k_true * math.sqrt(TAU0), n)), FS)
    keep = readable(walk, n) & (walk.tau_s >= 8 * TAU0)
    expected = k_true * np.sqrt(walk.tau_s[keep] / 3.0)
    assert np.all(np.abs(walk.adev[keep] - expected) <= 4.0 * walk.adev_err[keep])
    assert keep.sum() >= 9


def test_white_plus_random_walk_reads_the_bottom_of_the_bowl() -> None:
    n_true, k_true = 0.1, 0.0346  # deg/h·√s, deg/h/√s
    n = 2**19
    rng = np.random.default_rng(4)
    y = rng.normal(0.0, n_true / math.sqrt(TAU0), n)
    y += np.cumsum(rng.normal(0.0, k_true * math.sqrt(TAU0), n))
    c = allan_deviation(y, FS)
    p = noise_parameters(c)
    tau_star = math.sqrt(3.0) * n_true / k_true  # 5.0 s
    sigma_min = math.sqrt(2.0 * n_true * k_true / math.sqrt(3.0))
    assert p.b is not None and p.b_tau_s is not None
    # the octave grid lands within a factor √2 of τ*, where σ is ≤ 3 % above the bottom;
    # the point there has a relative 1σ of ~2 %
    assert tau_star / 2.0 <= p.b_tau_s <= tau_star * 2.0
    assert p.b * BIAS_INSTABILITY_FACTOR == pytest.approx(sigma_min * 1.01, rel=0.08)
    assert p.b == pytest.approx(c.adev.min() / 0.664, rel=1e-3)
    # the minimum lies between the two slopes
    assert p.n_tau_s is not None and p.k_tau_s is not None
    assert p.n_tau_s[1] < p.b_tau_s < p.k_tau_s[0]
    assert p.n == pytest.approx(n_true, rel=0.03)
    # K comes from the long-τ end only (20-80 s, relative 1σ 4-9 % per point)
    assert p.k == pytest.approx(k_true, rel=0.20)


def test_flicker_floor_gives_bias_instability() -> None:
    b_true, n_true = 0.01, 0.01  # deg/h, deg/h·√s
    n = 2**19
    rng = np.random.default_rng(5)
    y = flicker(rng, b_true, n) + rng.normal(0.0, n_true / math.sqrt(TAU0), n)
    p = noise_parameters(allan_deviation(y, FS))
    # the floor is read as the lowest of several flat points with relative 1σ ≤ 10 %
    assert p.b == pytest.approx(b_true, rel=0.15)
    assert p.n == pytest.approx(n_true, rel=0.03)
    assert p.n_tau_s is not None and p.b_tau_s is not None and p.n_tau_s[1] < p.b_tau_s
    assert p.k is None


def test_too_short_a_curve_has_no_parameters() -> None:
    y = np.random.default_rng(6).normal(size=60)
    p = noise_parameters(allan_deviation(y, FS))  # < 51 clusters beyond m = 1
    assert (p.n, p.b, p.k) == (None, None, None)
    assert noise_parameters(allan_deviation(np.ones(100), FS)).n is None  # σ = 0


# ---------------------------------------------------------------------------------- gaps


def test_nan_gaps_pool_the_stretches_and_never_bridge_them() -> None:
    rng = np.random.default_rng(7)
    y = rng.normal(0.0, 1.0, 3000)
    y[[0, 1, 1000, 1001, 1002, 2500, 2503, 2999]] = np.nan  # 2501-2502: two samples, unused
    shifted = y.copy()
    shifted[1003:] += 500.0  # a turn-on step across the gap
    c = allan_deviation(y, FS)
    assert np.all(np.isfinite(c.adev)) and np.all(np.isfinite(c.adev_err))
    np.testing.assert_allclose(allan_deviation(shifted, FS).adev, c.adev, rtol=1e-9)
    stretches = [y[2:1000], y[1003:2500], y[2504:2999]]
    for j, tau in enumerate(c.tau_s):
        m = round(tau * FS)
        parts = [oavar_reference(s, m) for s in stretches if s.size >= 2 * m + 1]
        pairs = sum(k for _, k in parts)
        assert c.n_pairs[j] == pairs
        assert c.adev[j] == pytest.approx(math.sqrt(sum(v * k for v, k in parts) / pairs))
    # the longest stretch (1497 samples) sets the longest τ: m ≤ 748
    assert round(c.tau_s[-1] * FS) == 512


def test_dict_and_dataframe_helpers() -> None:
    rng = np.random.default_rng(8)
    data = {"gyro_x": rng.normal(size=400), "accel_z": rng.normal(size=400)}
    curves = allan_deviations(data, FS)
    assert list(curves) == ["gyro_x", "accel_z"]
    np.testing.assert_array_equal(curves["accel_z"].adev, allan_deviation(data["accel_z"], FS).adev)
    frame = allan_deviations(pd.DataFrame(data), FS, taus="decade")
    assert list(frame) == ["gyro_x", "accel_z"] and len(frame["gyro_x"]) == 7
    data["gyro_x"] = np.full(400, np.nan)
    with pytest.raises(ValueError, match="channel gyro_x needs at least 3 consecutive"):
        allan_deviations(data, FS)


# -------------------------------------------------------------------------------- errors


@pytest.mark.parametrize(
    ("y", "rate", "taus", "message"),
    [
        (np.zeros((10, 2)), FS, "octave", r"y must be 1-D"),
        (np.full(10, np.nan), FS, "octave", r"y needs at least 3 consecutive .* 0 finite"),
        ([1.0, 2.0, np.nan, 3.0, 4.0], FS, "octave", r"longest NaN-free stretch 2"),
        ([1.0, np.inf, 2.0, 3.0], FS, "octave", r"y holds ±inf at sample 1"),
        (["a", "b", "c"], FS, "octave", r"y must be an array of numbers"),
        (np.zeros(10), 0.0, "octave", r"rate_hz must be a positive"),
        (np.zeros(10), float("nan"), "octave", r"rate_hz must be a positive"),
        (np.zeros(10), "fast", "octave", r"rate_hz must be a positive"),
        (np.zeros(10), FS, "weekly", r"taus must be 'octave', 'decade', 'all'"),
        (np.zeros(10), FS, [], r"taus must be a non-empty array"),
        (np.zeros(10), FS, [0.001], r"taus: 0.001 s is shorter than the sample interval"),
        (np.zeros(10), FS, [0.05], r"taus: 0.05 s needs 11 consecutive .* has 10"),
    ],
)
def test_errors_name_the_parameter(y, rate, taus, message) -> None:
    with pytest.raises(ValueError, match=message):
        allan_deviation(y, rate, taus=taus)


def test_noise_parameter_options_are_checked() -> None:
    c = allan_deviation(np.random.default_rng(9).normal(size=100), FS)
    with pytest.raises(ValueError, match="slope_tol"):
        noise_parameters(c, slope_tol=0.3)
    with pytest.raises(ValueError, match="max_rel_err"):
        noise_parameters(c, max_rel_err=0.0)


# -------------------------------------------------------------------------------- figure


def test_allan_figure_draws_one_log_log_panel_per_channel() -> None:
    rng = np.random.default_rng(10)
    n = 2**15
    walk = np.cumsum(rng.normal(0.0, 0.2 * math.sqrt(TAU0), n))
    raw = rng.normal(0.0, 3.0, n) + walk
    curves = {
        "gyro_x": {"raw": allan_deviation(raw, FS), "compensated": allan_deviation(raw - walk, FS)},
        "accel_z": {"raw": allan_deviation(rng.normal(0.0, 50.0, n), FS)},
    }
    fig = allan_figure(curves, {"gyro_x": "deg/h", "accel_z": "ug"})
    assert isinstance(fig, Figure)
    axes = [ax for ax in fig.axes if ax.axison]
    assert len(axes) == 2
    assert all(ax.get_xscale() == "log" and ax.get_yscale() == "log" for ax in axes)
    assert axes[0].get_ylabel() == "Allan deviation [°/h]"
    labels = [t.get_text() for t in axes[0].get_legend().get_texts()]
    assert labels[0].startswith("raw: N ") and "°/h·√s" in labels[0]
    assert any("slope −½" in t for t in labels) and any("slope +½" in t for t in labels)
    assert [ln.get_linestyle() for ln in axes[0].lines if "slope" in ln.get_label()] == [":"] * 2
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=40)
    assert buf.getvalue().startswith(b"\x89PNG")
    with pytest.raises(ValueError, match="at least one channel"):
        allan_figure({}, {})
    with pytest.raises(ValueError, match="holds no curve"):
        allan_figure({"gyro_x": {}}, {})
