"""The equilibrated Vandermonde design of :func:`rinscal.calibration.regression.polynomial_fit`
in one numba pass (private; compiled once and cached on disk, ``nogil``).

``np.polyfit`` (and :func:`~rinscal.calibration.regression.polynomial_fit`, the same numbers)
forms ``A = np.vander(x, degree + 1)``, the norm of each column ``sqrt((A * A).sum(axis=0))``
and ``A`` divided by it, column-major, for LAPACK: four passes over an ``n × (degree + 1)``
array and two temporaries as large. :func:`equilibrated_vander` writes the column-major
result directly from ``x``, each power made as ``np.vander`` makes it (the previous power
times ``x``, ``np.multiply.accumulate``) and each column's sum of squares added row by row
from the first, as numpy's reduction over the rows of a row-major array adds them: the same
numbers to the last bit (tested), in one pass over ``x`` and one over each column.
``auto``'s ArduPilot candidate fits its cubic on up to a million smoothed samples per
channel; this is most of its cost.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["equilibrated_vander"]


@numba.njit(cache=True, nogil=True, error_model="numpy")  # x / 0: inf or nan, as numpy
def _design(x, out, scale):  # pragma: no cover - numba
    """``scale[j]`` = the norm of column ``j`` of ``np.vander(x, k)`` (``k`` = columns of
    ``out``), ``out`` = that column divided by it."""
    n, k = out.shape
    ss = np.zeros(k)
    for i in range(n):
        p = 1.0
        for j in range(k - 1, -1, -1):  # the last column is x**0
            if j == k - 2:
                p = x[i]
            elif j < k - 2:
                p = p * x[i]
            out[i, j] = p
            if i == 0:
                ss[j] = p * p
            else:
                ss[j] += p * p
    for j in range(k):
        scale[j] = np.sqrt(ss[j])
        for i in range(n):  # each column divided in place, contiguous
            out[i, j] = out[i, j] / scale[j]


def equilibrated_vander(x: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """``np.vander(x, degree + 1)`` divided by the norm of each column, column-major, and
    those norms.

    Parameters
    ----------
    x : ndarray, shape (n,) [unit of x], n ≥ 1
    degree : int
        At least 0.

    Returns
    -------
    design : ndarray, shape (n, degree + 1), column-major
    scale : ndarray, shape (degree + 1,) [unit of x^(degree − j)]
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    out = np.empty((x.size, int(degree) + 1), order="F")
    scale = np.empty(int(degree) + 1)
    _design(x, out, scale)
    return out, scale
