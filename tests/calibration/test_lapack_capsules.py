"""scipy's LAPACK called through ctypes (rinscal.calibration._lapack, issue 39): the QR's
triangular factor of dgeqrf is numpy's to the bit, R'R reproduces A'A, the function is looked
up once, and threads calling it at once each get their own matrix's factor."""

from __future__ import annotations

import ctypes
import threading

import numpy as np
import pytest

from rinscal.calibration._lapack import lapack_function


def _dgeqrf_r(a: np.ndarray) -> np.ndarray:
    """R of A by LAPACK's dgeqrf called here directly (workspace query, then the factor)."""
    a = np.array(a, dtype=np.float64, order="F")
    m, n = a.shape
    tau = np.empty(min(m, n))
    info = ctypes.c_int(0)
    rows, cols = ctypes.c_int(m), ctypes.c_int(n)
    f = lapack_function("dgeqrf", "iipippii")
    query = np.empty(1)
    f(rows, cols, a.ctypes.data, rows, tau.ctypes.data, query.ctypes.data, ctypes.c_int(-1), info)
    work = np.empty(max(1, int(query[0])))
    f(rows, cols, a.ctypes.data, rows, tau.ctypes.data, work.ctypes.data,
      ctypes.c_int(work.size), info)  # fmt: skip
    assert info.value == 0
    return np.triu(a[: min(m, n)])


@pytest.mark.parametrize("shape", [(50, 4), (7, 7), (3, 5), (2000, 12)])
def test_dgeqrf_gives_numpys_r(shape: tuple[int, int]) -> None:
    rng = np.random.default_rng(sum(shape))
    a = rng.normal(size=shape)
    r = _dgeqrf_r(a)
    np.testing.assert_array_equal(r, np.linalg.qr(a, mode="r"))
    np.testing.assert_allclose(r.T @ r, a.T @ a, rtol=1e-10, atol=1e-10)


def test_looked_up_once_and_called_from_threads() -> None:
    assert lapack_function("dgeqrf", "iipippii") is lapack_function("dgeqrf", "iipippii")
    rng = np.random.default_rng(1)
    mats = [rng.normal(size=(4000, 10)) for _ in range(4)]
    want = [np.linalg.qr(m, mode="r") for m in mats]
    got: dict[int, np.ndarray] = {}
    threads = [
        threading.Thread(target=lambda i=i: got.__setitem__(i, _dgeqrf_r(mats[i])))
        for i in range(4)
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for i in range(4):
        np.testing.assert_array_equal(got[i], want[i])
