"""One least-squares solve (issue 37.6): known answers, np.polyfit's own numbers, one place."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import rinscal.calibration
from rinscal.calibration.regression import least_squares, polynomial_fit


def test_an_exact_polynomial_is_recovered() -> None:
    x = np.linspace(-10.0, 60.0, 25)
    y = 2.0 - 3.0 * x + 0.5 * x**3
    np.testing.assert_allclose(polynomial_fit(x, y, 3), [0.5, 0.0, -3.0, 2.0], atol=1e-9)
    # np.polyfit's numbers, to the last bit (the field's cubics were np.polyfit), on noise too
    noisy = y + np.random.default_rng(1).standard_normal(x.size)
    assert np.array_equal(polynomial_fit(x, noisy, 3), np.polyfit(x, noisy, 3))
    two = np.column_stack([noisy, 2 * noisy])
    assert np.array_equal(polynomial_fit(x, two, 1), np.polyfit(x, two, 1))


def test_weights_follow_the_standard_deviations() -> None:
    """A line y = 1 + 2x and one wild point: with its sd 1e9 times the others' it leaves the
    line where it is; weighted alike it pulls it."""
    x = np.arange(10.0)
    y = 1.0 + 2.0 * x
    y[4] += 100.0
    a = np.column_stack([np.ones_like(x), x])
    sd = np.ones_like(x)
    sd[4] = 1e9
    np.testing.assert_allclose(least_squares(a, y, sd), [1.0, 2.0], rtol=1e-9)
    assert abs(least_squares(a, y)[0] - 1.0) > 5.0
    # a 2-D y is fitted column by column, with the same weights
    both = least_squares(a, np.column_stack([y, 3 * y]), sd)
    np.testing.assert_allclose(both, [[1.0, 3.0], [2.0, 6.0]], rtol=1e-9)


def test_equilibration_changes_only_the_conditioning() -> None:
    rng = np.random.default_rng(2)
    a = rng.standard_normal((50, 3)) * [1.0, 1e3, 1e-3]
    y = a @ [1.0, 2.0, 3.0] + 1e-3 * rng.standard_normal(50)
    np.testing.assert_allclose(
        least_squares(a, y, equilibrate=True), least_squares(a, y), rtol=1e-10
    )


def test_the_calibration_code_solves_least_squares_in_one_place() -> None:
    """No other lstsq or polyfit call in rinscal.calibration (their names quoted in a
    docstring are not calls): a regression goes through here."""
    root = Path(rinscal.calibration.__file__).parent
    found = [
        f"{p.relative_to(root)}:{i}"
        for p in root.rglob("*.py")
        if p.name != "regression.py"
        for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        if re.search(r"(?<![`\w.])(np|numpy)\.(linalg\.lstsq|polyfit)\(", line)  # not in ``
    ]
    assert not found, found


def test_the_solve_is_numpy_s_lstsq_to_the_bit() -> None:
    """scipy's ``dgelsd``, called with the GIL released, gives ``np.linalg.lstsq(a, y,
    rcond=None)[0]`` bit for bit: tall, square and wide designs, rank-deficient ones (the
    minimum-norm solution, numpy's cut-off), one or several right-hand sides."""
    rng = np.random.default_rng(7)
    for m in (1, 3, 4, 7, 50, 20_000):
        for n in (1, 2, 4, 8):
            for deficient in (False, True):
                a = rng.normal(size=(m, n)) * rng.uniform(0.01, 100, n)
                if deficient and n > 1:
                    a[:, -1] = 2 * a[:, 0]
                for y in (rng.normal(size=m), rng.normal(size=(m, 3))):
                    want = np.linalg.lstsq(a, y, rcond=None)[0]
                    got = least_squares(a, y)
                    assert got.shape == want.shape and got.tobytes() == want.tobytes()
                    # equilibrated (np.polyfit's way): the columns scaled, the solve unscaled
                    scale = np.sqrt((a * a).sum(axis=0))
                    want = (np.linalg.lstsq(a / scale, y, rcond=None)[0].T / scale).T
                    got = least_squares(a, y, equilibrate=True)
                    assert got.shape == want.shape and got.tobytes() == want.tobytes()


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(1, 3000),
    degree=st.integers(0, 5),
    centre=st.floats(-50, 50),
    seed=st.integers(0, 2**32 - 1),
)
def test_the_one_pass_design_is_np_vander_equilibrated_to_the_bit(
    n: int, degree: int, centre: float, seed: int
) -> None:
    """:func:`rinscal.calibration._vander.equilibrated_vander` is ``np.vander`` divided by
    its column norms (as ``np.polyfit`` forms them) bit for bit, and ``polynomial_fit`` on
    its path (many samples, numba loaded) is ``np.polyfit`` to the last bit."""
    from rinscal.calibration import regression
    from rinscal.calibration._vander import equilibrated_vander

    rng = np.random.default_rng(seed)
    x = centre + rng.normal(0.0, 10.0, n)
    a = np.vander(x, degree + 1)
    scale = np.sqrt((a * a).sum(axis=0))
    design, got_scale = equilibrated_vander(x, degree)
    assert design.flags.f_contiguous
    assert got_scale.tobytes() == scale.tobytes()
    assert design.tobytes(order="F") == (a / scale).tobytes(order="F")
    if n > degree:
        y = 3.0 - 0.2 * x + 1e-3 * x**3 + rng.normal(0.0, 0.5, n)
        old = regression._KERNEL_ROWS
        try:
            regression._KERNEL_ROWS = 1  # the kernel path at this size
            assert np.array_equal(polynomial_fit(x, y, degree), np.polyfit(x, y, degree))
        finally:
            regression._KERNEL_ROWS = old


def test_the_one_pass_design_divides_by_a_zero_norm_as_numpy_does() -> None:
    """A column of zeros (every x 0): its norm is 0 and the division gives NaN, as numpy's
    (with its warning); the kernel does not raise."""
    import warnings

    from rinscal.calibration._vander import equilibrated_vander

    x = np.zeros(7)
    design, scale = equilibrated_vander(x, 3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        a = np.vander(x, 4)
        want = a / np.sqrt((a * a).sum(axis=0))
    assert scale.tolist() == [0.0, 0.0, 0.0, np.sqrt(7.0)]
    assert np.array_equal(design, want, equal_nan=True)
