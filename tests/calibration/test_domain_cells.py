"""The joint domain's cells (issue 39): numba's one-pass kernel gives the cell numbers of the
numpy passes to the bit, for one to three inputs, contiguous or strided, values outside the
range, NaN and infinities included (numpy's cast of those gives the least int64, clipped to
cell 0), and the domain built and tested with either is the same."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rinscal import _kernels
from rinscal.calibration._domain import (
    _flat_cells_numpy,
    _inside_numpy,
    fit_domain,
    inside_domain,
)


@settings(max_examples=150, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 400),
    k=st.integers(1, 3),
    bins=st.integers(1, 30),
    strided=st.booleans(),
    odd=st.booleans(),
)
def test_kernel_cells_are_numpys(
    seed: int, n: int, k: int, bins: int, strided: bool, odd: bool
) -> None:
    rng = np.random.default_rng(seed)
    x = rng.normal(scale=30.0, size=(n, 3))
    if odd:  # outside the range, at its edges, not numbers, beyond int64
        pick = rng.integers(0, n, size=min(n, 8))
        x[pick, rng.integers(0, 3, size=pick.size)] = rng.choice(
            [np.nan, np.inf, -np.inf, 1e300, -1e300, 1e19, 0.0], size=pick.size
        )
    lo = np.array([-20.0, 0.0, 5.0])[:k]
    hi = np.array([20.0, 0.0, 45.0])[:k]  # the second input constant: width 1
    nb = np.full(k, bins, dtype=np.int64)
    cols = [x[:, v] if strided else np.ascontiguousarray(x[:, v]) for v in range(k)]
    with np.errstate(invalid="ignore"):
        want = _flat_cells_numpy(cols, lo, hi, nb)
    c = [cols[min(v, k - 1)] for v in range(3)]
    got = np.empty(n, dtype=np.int64)
    _kernels.flat_cells(c[0], c[1], c[2], k, lo, hi, nb, got)
    np.testing.assert_array_equal(got, want)
    assert np.all((got >= 0) & (got < np.prod(nb)))
    # and the whole test of the domain: cell occupied and every input within a cell of it
    grid = rng.random(int(np.prod(nb))) < 0.5
    xs = np.column_stack(cols)
    with np.errstate(invalid="ignore"):
        want_in = _inside_numpy(xs, lo, hi, nb, grid, np.empty(n, dtype=bool))
    got_in = np.empty(n, dtype=bool)
    _kernels.inside_cells(c[0], c[1], c[2], k, lo, hi, nb, grid, got_in)
    np.testing.assert_array_equal(got_in, want_in)


@pytest.mark.parametrize("k", [1, 2, 3])
def test_domain_inside_is_the_training_data(k: int) -> None:
    """A sample of the training data is inside its domain; one far from it is not."""
    rng = np.random.default_rng(k)
    t = rng.uniform(0.0, 50.0, 20000)
    x = np.column_stack([t, 0.1 * t + rng.normal(size=t.size), 30.0 - 0.2 * t][:k])
    d = fit_domain(x)
    assert inside_domain(d, x).all()
    far = x[:10].copy()
    far[:, 0] = 200.0
    assert not inside_domain(d, far).any()
