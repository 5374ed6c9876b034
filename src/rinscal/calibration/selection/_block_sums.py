"""Sums of a design's columns over averaging blocks in one numba pass (private; compiled once
and cached on disk, ``nogil``).

``auto`` scores its polynomial candidates on the means of 60 s blocks of ``[A | y]``
(:func:`rinscal.calibration.selection.auto._polynomial_scores`): each column summed over
each block with ``np.bincount(ids, weights=column)``, one call a column. :func:`block_sums`
adds every column in one call, each one row after the other into its block from 0, as
``bincount`` adds: the same numbers to the last bit (tested).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["block_sums"]


@numba.njit(cache=True, nogil=True)
def _sums(ids, a, y, out):  # pragma: no cover - numba
    m, k = a.shape
    for j in range(k):  # column by column: a is column-major
        for i in range(m):
            out[ids[i], j] += a[i, j]
    for i in range(m):
        out[ids[i], k] += y[i]


def block_sums(ids: np.ndarray, a: np.ndarray, y: np.ndarray, n_blocks: int) -> np.ndarray:
    """``[bincount(ids, a[:, 0]), …, bincount(ids, y)]`` as the columns of one array.

    Parameters
    ----------
    ids : ndarray of int, shape (m,)
        Block of each row, in ``[0, n_blocks)``.
    a : ndarray, shape (m, k) [unit of each column]
        Design rows (column-major is read fastest).
    y : ndarray, shape (m,) [unit of y]
    n_blocks : int

    Returns
    -------
    ndarray, shape (n_blocks, k + 1)
    """
    out = np.zeros((int(n_blocks), a.shape[1] + 1))
    if ids.size:
        _sums(
            np.ascontiguousarray(ids, dtype=np.int64),
            np.asarray(a, dtype=np.float64),
            np.ascontiguousarray(y, dtype=np.float64),
            out,
        )
    return out
