"""Issue 39: the blocked QR of ``[A | y]`` factors blocks of 16 384 rows, each expanded in
place into one buffer; the factor is the one of before (blocks of 2^18 rows cut into the same
16 384-row pieces), to the bit, and the fits agree with a dense least-squares solve."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from rinscal.calibration.thermal.fitting import (
    PowerBasis,
    center_scale,
    power_basis,
    qr_r,
    solve_r,
    tsqr,
)
from rinscal.calibration.thermal.runs import RunFits


def _old_tsqr(basis, x, y, n_terms, block=1 << 18, sub=1 << 14):
    """The factorisation before issue 39: the basis of 2^18 rows at a time, copied into
    ``[A | y]`` and factored in 16 384-row pieces."""
    rs = []
    for s in range(0, x.shape[0], block):
        a = basis(x[s : s + block])
        aug = np.empty((a.shape[0], n_terms + 1), order="F")
        aug[:, :n_terms] = a
        aug[:, n_terms] = y[s : s + block]
        for u in range(0, aug.shape[0], sub):
            rs.append(np.linalg.qr(aug[u : u + sub], mode="r"))
    return rs[0] if len(rs) == 1 else np.linalg.qr(np.vstack(rs), mode="r")


def _inputs(n, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    temp = 20 + 15 * np.tanh((t - t.mean()) / (0.3 * t[-1] + 1))
    rate = np.gradient(temp, t) * 60 + rng.normal(0, 0.01, n)
    grad = rng.normal(1.0, 0.3, n)
    x = np.column_stack([temp, rate, grad])
    y = 1e6 + 40 * (temp - 25) + 0.3 * (temp - 25) ** 3 - 80 * rate + rng.normal(0, 50, n)
    return x, y


@pytest.fixture(autouse=True)
def _one_blas_thread():
    """As ``fit`` factors (BLAS threads only wait on each other over such thin blocks)."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


@pytest.mark.parametrize("n", [1000, 16_384, 300_001])
@pytest.mark.parametrize("orders", [(3, 1, 1), (4, 3, 3)])
def test_the_factor_is_the_one_before_issue_39_to_the_bit(n, orders) -> None:
    x, y = _inputs(n)
    cs = [center_scale(x[:, v]) for v in range(3)]
    basis = power_basis([c for c, _ in cs], [s for _, s in cs], orders)
    assert isinstance(basis, PowerBasis)
    n_terms = 1 + sum(orders)
    new = tsqr(basis, x, y, n_terms)
    np.testing.assert_array_equal(new, _old_tsqr(basis, x, y, n_terms))
    # a plain callable (not a PowerBasis) is expanded and copied: the same factor
    np.testing.assert_array_equal(tsqr(lambda b: basis(b), x, y, n_terms), new)


def test_regression_from_run_factors_agrees_with_a_dense_solve() -> None:
    """Seven runs of 40 000 rows, ``regression`` (3, 3, 3) fitted from the per-run factors
    (as ``fit`` does) and by one dense least-squares solve of the whole design: the
    coefficients agree to 1e-9 relative (the accuracy of a QR solve, not of normal
    equations, whose error grows with the square of the condition number)."""
    fits = RunFits("regression", [3, 3, 3], keep_rows=False)
    xs, ys = [], []
    for k in range(7):
        x, y = _inputs(40_000, seed=k)
        x[:, 0] += 5 * k  # each run warmer
        fits.add(k, x, y, np.arange(x.shape[0]) * 0.01)
        xs.append(x)
        ys.append(y)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        params = fits.regression([3, 3, 3])
    x, y = np.vstack(xs), np.concatenate(ys)
    basis = power_basis(params["center"], params["scale"], params["orders"])
    beta_dense = np.linalg.lstsq(basis(x), y, rcond=None)[0]
    beta = np.concatenate([[params["intercept"]], *map(np.asarray, params["coef"])])
    np.testing.assert_allclose(beta, beta_dense, rtol=1e-9, atol=1e-9 * np.abs(beta_dense).max())
    # and the residual sum of squares from the factor is the dense one
    r = tsqr(basis, x, y, basis.n_terms)
    rss = solve_r(r, basis.n_terms)[1]
    dense = float(np.sum((basis(x) @ beta_dense - y) ** 2))
    assert rss == pytest.approx(dense, rel=1e-9)


@pytest.mark.parametrize(
    "shape", [(1, 1), (1, 5), (5, 12), (13, 13), (100, 13), (16_384, 12), (3000, 40), (200, 200)]
)
def test_qr_r_is_numpy_s_triangular_factor_to_the_bit(shape) -> None:
    """:func:`qr_r` (scipy's LAPACK ``dgeqrf``, called directly) gives numpy's
    ``qr(mode="r")``: tall, square and wide matrices, the blocked LAPACK path (more than 32
    columns) too, either memory order, factored in place or not."""
    a = np.random.default_rng(shape[0] * 1000 + shape[1]).normal(size=shape)
    want = np.linalg.qr(a, mode="r")
    for m in (a, np.asfortranarray(a)):
        kept = m.copy()
        got = qr_r(m)
        assert got.shape == want.shape and got.tobytes() == want.tobytes()
        np.testing.assert_array_equal(m, kept)  # not overwritten unless asked
    f = np.asfortranarray(a)
    assert qr_r(f, overwrite=True).tobytes() == want.tobytes()
    assert qr_r(np.zeros((0, 3))).shape == (0, 3)
