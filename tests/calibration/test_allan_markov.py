"""The exponentially correlated (Gauss-Markov) angle noise as a term of the Allan fit.

A dithered laser gyro's slowly wandering angle (sd ``M``, correlation time ``τc``) has the
Allan variance ``M²(3 − 4e^{−τ/τc} + e^{−2τ/τc})/τ²`` (``markov_angle_avar``): slope −1/2
like an angle random walk of ``√2 M/√τc`` below τc, −1 beyond. Checked here against a
simulated Markov angle through allantools, and the fit against synthetic records: where the
record reaches well beyond τc, M, τc and N are recovered; on a 10 min record the random walk
is not told from the correlated noise and is said so (a bound the truth lies under).
"""

from __future__ import annotations

import math

import allantools
import numpy as np
import pytest

from rinscal.calibration.allan import (
    allan_deviation,
    fit_noise_terms,
    markov_angle_avar,
    pool_curves,
)


def markov_angle(rng: np.random.Generator, m: float, tau_c: float, n: int) -> np.ndarray:
    """A first-order Gauss-Markov series of stationary sd m at 1 s steps (exact AR(1))."""
    a = math.exp(-1.0 / tau_c)
    e = rng.normal(0.0, m * math.sqrt(1.0 - a * a), n)
    x = np.empty(n)
    x[0] = rng.normal(0.0, m)
    for i in range(1, n):
        x[i] = a * x[i - 1] + e[i]
    return x


def record(rng, n, *, q=2.0, m=6.0, tau_c=100.0, arw=0.45):
    """Per-second rates [″/s]: white angle q [″], Markov angle m [″] over tau_c [s], ARW
    arw [″/√s] (0.45 ″/√s = 0.0075 °/√h)."""
    angle = rng.normal(0.0, q, n + 1) + markov_angle(rng, m, tau_c, n + 1)
    return np.diff(angle) + rng.normal(0.0, arw, n)


def test_the_markov_angle_allan_variance_is_the_simulated_one() -> None:
    rng = np.random.default_rng(41)
    m, tau_c = 1.0, 20.0
    y = np.diff(markov_angle(rng, m, tau_c, 400_001))  # rates of the angle, 1 Hz
    taus = np.array([1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0])
    t, ad, _, _ = allantools.oadev(y, rate=1.0, data_type="freq", taus=taus)
    want = m * np.sqrt(markov_angle_avar(t, tau_c))
    np.testing.assert_allclose(ad, want, rtol=0.05)
    np.testing.assert_allclose(allan_deviation(y, 1.0, t).adev, ad, rtol=1e-9)
    # the limits: a random walk of √2 M/√τc well below τc, white angle noise M far above
    assert markov_angle_avar(0.01, tau_c) == pytest.approx(2 * m * m / (0.01 * tau_c), rel=1e-3)
    assert markov_angle_avar(1e4, tau_c) == pytest.approx(3 * m * m / 1e8, rel=1e-3)


def test_a_long_record_separates_the_random_walk_from_the_correlated_angle() -> None:
    """3 h at 1 Hz, three axes: τ reaches 50 τc; M, τc and N all come back."""
    rng = np.random.default_rng(42)
    curves = [allan_deviation(record(rng, 10_800), 1.0) for _ in range(3)]
    f = fit_noise_terms(pool_curves(curves))
    assert f.tau_c_s is not None and f.markov_weight > 0.5
    assert 50.0 <= f.tau_c_s <= 200.0  # τc = 100 s
    assert f.m.value == pytest.approx(6.0, rel=0.3)
    assert f.n.resolved and 1 / 1.5 <= f.n.value / 0.45 <= 1.5
    assert f.q.value == pytest.approx(2.0, rel=0.3)
    # without the term, the correlated angle is read as a random walk twice the truth
    five = fit_noise_terms(pool_curves(curves), correlated=False)
    assert five.n.value > 1.5 * 0.45


@pytest.mark.parametrize("seed", range(43, 53))
def test_a_ten_minute_window_says_what_it_cannot_tell(seed: int) -> None:
    """600 s, three axes, the ring-laser preset's noise: N within 1.5× where resolved,
    else a bound above the truth; the filter's N never the correlated noise's sum with
    it beyond the bound."""
    rng = np.random.default_rng(seed)
    taus = [1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256, 299]  # as noise.py
    curves = [allan_deviation(record(rng, 600), 1.0, taus) for _ in range(3)]
    f = fit_noise_terms(pool_curves(curves))
    if f.n.resolved:
        assert 1 / 1.5 <= f.n.value / 0.45 <= 1.5
    else:
        assert f.n.bound is not None and f.n.bound >= 0.45
    value, _ = f.n_for_filter()
    assert 0.0 < value <= f.n.bound
