"""The IEEE Std 952 five-term fit of an Allan variance curve (``fit_noise_terms``).

Expected values are the textbook processes' own, not the code's:

* white angle noise (quantisation) of sd ``Q`` per sample of the angle: the rate samples
  are its first differences over ``τ0``, and ``σ(τ) = √3 Q/τ`` exactly at every
  ``τ = m τ0`` (see ``analytic_white_angle``; IEEE 952 Annex C);
* white rate noise of sd ``σ`` at ``τ0``: ``N = σ √τ0``, ``σ(τ) = N/√τ``;
* a rate random walk with steps ``K √τ0``: ``σ²(τ) = K² τ/3``;
* integer counts ``q`` with the remainder carried (a pulse-output gyro): the angle read is
  the true one less a remainder uniform in ``[0, q)`` once a little noise dithers it, so
  ``Q = q/√12``.

The weights are the clusters of each τ (IEEE 952; El-Sheimy, Hou & Niu 2008): every τ of
the record enters, the long ones with little weight.
"""

from __future__ import annotations

import math

import allantools
import numpy as np
import pytest

from rinscal.calibration.allan import (
    AllanCurve,
    allan_deviation,
    fit_noise_terms,
    pool_curves,
)
from rinscal.errors import ConfigError


def analytic_white_angle(q: float, tau: np.ndarray, tau0: float) -> np.ndarray:
    """σ(τ) of rates that are first differences of white angle noise of sd q, at τ = mτ0.

    The mean rate over τ is ``(θ_{k+m} − θ_k)/τ`` plus the true rate, so the second
    difference of angles ``e_{k+2m} − 2e_{k+m} + e_k`` has variance ``6q²`` and
    ``σ²(τ) = 6q²/(2τ²) = 3q²/τ²`` exactly, at every m.
    """
    return math.sqrt(3.0) * q / tau


def white_angle(rng: np.random.Generator, q: float, n: int, rate: float) -> np.ndarray:
    e = rng.normal(0.0, q, n + 1)
    return np.diff(e) * rate


def test_white_angle_noise_is_q_and_no_random_walk() -> None:
    rng = np.random.default_rng(11)
    q, rate = 2.0, 1.0  # e.g. 2″ of white angle noise, per-second rates in ″/s
    y = white_angle(rng, q, 3600, rate)
    c = allan_deviation(y, rate)
    np.testing.assert_allclose(c.adev[:6], analytic_white_angle(q, c.tau_s[:6], 1.0), rtol=0.1)
    f = fit_noise_terms(c)
    assert f.q.resolved and f.q.value == pytest.approx(q, rel=0.05)
    assert f.q.dominant_tau_s is not None and f.q.dominant_tau_s[0] == 1.0
    assert not f.n.resolved
    # the random walk is bounded by the curve: (σ + 2σ)·√τ at the longest reliable τ, the
    # 1σ of a deviation over M clusters 1/√(2(M − 1)) (IEEE 952)
    assert f.n.bound is not None and f.n.bound_tau_s == f.tau_reliable_s
    m = float(c.clusters[np.flatnonzero(c.tau_s == f.tau_reliable_s)[0]])
    widen = 1.0 + 2.0 / math.sqrt(2.0 * (m - 1.0))
    analytic = math.sqrt(3.0) * q / math.sqrt(f.tau_reliable_s)
    assert f.n.bound == pytest.approx(widen * analytic, rel=0.3)
    assert f.n.bound >= analytic
    value, resolved = f.n_for_filter()  # the fit's (≈ 0) where above 0, else the bound
    assert not resolved and value == (min(f.n.value, f.n.bound) if f.n.value > 0 else f.n.bound)
    assert value <= f.n.bound
    np.testing.assert_allclose(f.model(c.tau_s), math.sqrt(3.0) * q / c.tau_s, rtol=0.06)


def test_white_rate_noise_is_n_and_no_quantisation() -> None:
    rng = np.random.default_rng(12)
    rate, sd = 100.0, 0.5  # deg/h per sample at 100 Hz: N = 0.05 deg/h·√s
    y = rng.normal(0.0, sd, 100 * 600)
    f = fit_noise_terms(allan_deviation(y, rate))
    n_true = sd / math.sqrt(rate)
    # on 600 s, a correlated angle noise of τc ≈ 300 s could stand in for N: the fit's N is
    # right, resolved or not, and the filter gets it
    assert f.n.value == pytest.approx(n_true, rel=0.05)
    told, resolved = f.n_for_filter()
    assert resolved == f.n.resolved and told == pytest.approx(n_true, rel=0.05)
    assert f.tau_c_s is None  # no correlated noise kept
    assert not f.q.resolved and not f.k.resolved and not f.r.resolved
    # the bound (σ + 1σ)·√τ, the smallest over τ: the truth under it, to the 1σ of the
    # best-determined point (60 000 clusters at 0.01 s: 0.3 %)
    assert f.n.bound is not None and f.n.bound >= 0.99 * n_true


def test_white_angle_plus_white_rate_both_resolved_where_the_record_reaches() -> None:
    rng = np.random.default_rng(13)
    q, n = 1.0, 0.5  # crossing at τ = 3q²/n² = 12 s
    y = white_angle(rng, q, 7200, 1.0) + rng.normal(0.0, n, 7200)
    f = fit_noise_terms(allan_deviation(y, 1.0))
    assert f.q.resolved and f.q.value == pytest.approx(q, rel=0.1)
    assert f.n.resolved and f.n.value == pytest.approx(n, rel=0.15)
    assert f.q.dominant_tau_s[1] < 12.0 < f.n.dominant_tau_s[0] + 12.0
    # a 10 min record whose random walk only meets the count at 300 s: a bound above it
    q2, n2 = 3.0, 0.3
    y2 = white_angle(rng, q2, 600, 1.0) + rng.normal(0.0, n2, 600)
    f2 = fit_noise_terms(allan_deviation(y2, 1.0))
    value, resolved = f2.n_for_filter()  # the fit's N, resolved or not
    assert value == pytest.approx(n2, rel=0.5)
    if not resolved:  # the truth under the bound; at τ = 32 s the count still weighs in:
        # √(3q²/τ + n²) = 0.97 = 3.2 n, widened by 2σ
        assert n2 <= f2.n.bound <= 5.0 * n2


def test_rate_random_walk_is_k() -> None:
    rng = np.random.default_rng(14)
    n_s, k, n = 40000, 0.01, 0.3  # 11 h at 1 Hz; K √τ0 steps, white rate N
    y = np.cumsum(rng.normal(0.0, k, n_s)) + rng.normal(0.0, n, n_s)
    f = fit_noise_terms(allan_deviation(y, 1.0))
    # N dominates only to 32 s: a correlated angle noise of τc ≥ 60 s with the rate random
    # walk beyond could stand in for it (the fit says so); the fit's N is right all the same
    assert f.n.value == pytest.approx(n, rel=0.1)
    assert f.n_for_filter()[0] == pytest.approx(n, rel=0.1)
    assert f.k.resolved and f.k.value == pytest.approx(k, rel=0.3)
    assert f.k.dominant_tau_s is not None and f.k.dominant_tau_s[1] == f.tau_reliable_s
    assert f.k.bound is not None and f.k.bound >= k


def test_integer_counts_with_the_remainder_carried_are_white_angle_noise() -> None:
    """A pulse-output gyro: 0.1″ counts at 100 Hz of 15 °/h plus a little dither noise."""
    rng = np.random.default_rng(15)
    fs, q = 100.0, 0.1  # Hz, arcsec
    n_s = int(fs * 1200)
    rate = 15.0  # ″/s (15 °/h)
    angle = np.cumsum(np.full(n_s, rate / fs)) + rng.normal(0.0, 0.3 * q, n_s)  # dither
    counts = np.floor(angle / q)
    y = np.diff(counts, prepend=0.0) * q * fs  # ″/s
    f = fit_noise_terms(allan_deviation(y, fs))
    # the dither's own white angle noise adds: Q² = q²/12 + (0.3 q)²
    q_true = math.sqrt(q**2 / 12.0 + (0.3 * q) ** 2)
    assert f.q.resolved and f.q.value == pytest.approx(q_true, rel=0.1)
    assert not f.n.resolved  # no random walk was put in; its bound is small
    assert f.n.bound < 0.015  # ″/√s, i.e. < 2.5e-4 °/√h (σ(82 s)·√82 widened by 2σ)
    # first differences read it as white rate noise: 60× the bound at 100 Hz
    first_diff = np.std(np.diff(y)) / math.sqrt(2.0) / math.sqrt(fs)
    assert first_diff > 30.0 * f.n.bound


def test_pooled_axes_are_the_mean_allan_variance_and_agree_with_allantools() -> None:
    rng = np.random.default_rng(16)
    ys = [rng.normal(0.0, s, 4000) for s in (1.0, 2.0, 3.0)]
    curves = [allan_deviation(y, 10.0) for y in ys]
    pooled = pool_curves(curves)
    ref = []
    for y in ys:
        t, ad, _, _ = allantools.oadev(y, rate=10.0, data_type="freq", taus=pooled.tau_s)
        np.testing.assert_allclose(t, pooled.tau_s)
        ref.append(ad**2)
    np.testing.assert_allclose(pooled.adev, np.sqrt(np.mean(ref, axis=0)), rtol=1e-9)
    np.testing.assert_allclose(pooled.clusters, sum(c.clusters for c in curves))
    # more clusters: a smaller relative error than any one axis
    assert np.all(pooled.adev_err / pooled.adev < curves[0].adev_err / curves[0].adev)
    with pytest.raises(ConfigError, match="share"):
        pool_curves([curves[0], allan_deviation(ys[0][:500], 10.0)])


def test_every_tau_is_used_and_weighted_by_its_clusters() -> None:
    """The long-τ tail with few clusters enters (unlike the slope reading's ≥ 51), with
    little weight: an outlier there moves the fit far less than one at short τ."""
    rng = np.random.default_rng(17)
    y = rng.normal(0.0, 1.0, 2000)
    c = allan_deviation(y, 1.0)
    f = fit_noise_terms(c)
    assert f.points == len(c) and f.tau_s[1] == c.tau_s[-1]
    assert c.clusters[-1] < 10  # a point the slope reading never sees

    def bumped(i: int) -> float:
        a = c.adev.copy()
        a[i] *= 2.0
        cc = AllanCurve(c.tau_s, a, c.adev_err, c.n_pairs, clusters=c.clusters)
        return fit_noise_terms(cc).n.value

    assert abs(bumped(len(c) - 1) / f.n.value - 1) < 0.2 * abs(bumped(0) / f.n.value - 1)
    with pytest.raises(ConfigError, match="at least 2 points"):
        fit_noise_terms(allan_deviation(y[:4], 1.0))


def test_the_non_negative_least_squares_is_scipys() -> None:
    """The exact small-problem NNLS (every support tried) against scipy's active set."""
    from scipy.optimize import nnls

    from rinscal.calibration import allan

    rng = np.random.default_rng(18)
    for _ in range(50):
        a = rng.normal(size=(12, 5)) * 10.0 ** rng.uniform(-6, 6, 5)
        y = rng.normal(size=12)
        want, _ = nnls(a, y)
        got = allan._nnls(a, y)
        assert np.linalg.norm(a @ got - y) <= np.linalg.norm(a @ want - y) * (1 + 1e-9) + 1e-12
        assert np.all(got >= 0)
