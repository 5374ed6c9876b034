"""PX4's 31-sample running median at chosen rows of a run only: a numba kernel (private).

``fit --method auto`` keeps every ``k``-th row of a log for its held-out choice, each with
the value of PX4's 31-sample running median centred on that row, computed on the whole run
(:class:`rinscal.calibration.thermal.runs.RowSample`, :func:`rinscal.calibration.thermal.
baselines.px4_median_filter`: zeros beyond the ends). :func:`medians_at` gives those medians
without filtering every other row. The median of an odd window is one of its samples, so the
numbers are the same to the last bit (a signed zero aside: ``-0.0`` and ``0.0`` compare equal).

Each window's median comes from a selection network: Batcher's odd-even merge sort of 32
values (the 31 of the window and +inf), pruned to the comparators the 16th smallest depends
on (:func:`median_network` builds it; the kernel writes those 152 compare-exchanges out, so
the window stays in registers). 35-50 ns a window against about 105 for numpy's partition
of a copied window (one core; :mod:`rinscal.calibration.thermal.runs` used that before).

Compiled once and cached on disk (``nogil``: the channels' threads run it at once).
"""

from __future__ import annotations

import numba
import numpy as np

from rinscal.calibration.thermal.baselines import PX4_MEDIAN_KERNEL

__all__ = ["median_network", "medians_at"]


def median_network(n: int = 32, rank: int = PX4_MEDIAN_KERNEL // 2) -> list[tuple[int, int]]:
    """The compare-exchanges ``(i, j)`` (``i < j``: the smaller value goes to ``i``) of
    Batcher's odd-even merge sort of ``n`` values (a power of two), in order, keeping only
    those that position ``rank`` depends on; those that touch position ``n − 1`` are dropped
    too (it holds +inf, the largest: such an exchange changes nothing)."""
    comps = []
    p = 1
    while p < n:
        k = p
        while k >= 1:
            for j in range(k % p, n - k, 2 * k):
                for i in range(min(k, n - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p):
                        comps.append((i + j, i + j + k))
            k //= 2
        p *= 2
    need, kept = {rank}, []
    for a, b in reversed(comps):
        if a in need or b in need:
            kept.append((a, b))
            need |= {a, b}
    return [(a, b) for a, b in reversed(kept) if b != n - 1]


@numba.njit(cache=True, nogil=True)
def _medians(y, keep, out):  # pragma: no cover - numba
    """``out[q]`` = the median of ``y[keep[q] − 15 : keep[q] + 16]``, zeros beyond the ends:
    the compare-exchanges of :func:`median_network`, written out."""
    n = y.shape[0]
    for q in range(keep.shape[0]):
        r = keep[q] - 15
        if r >= 0 and r + 31 <= n:
            v0 = y[r + 0]
            v1 = y[r + 1]
            v2 = y[r + 2]
            v3 = y[r + 3]
            v4 = y[r + 4]
            v5 = y[r + 5]
            v6 = y[r + 6]
            v7 = y[r + 7]
            v8 = y[r + 8]
            v9 = y[r + 9]
            v10 = y[r + 10]
            v11 = y[r + 11]
            v12 = y[r + 12]
            v13 = y[r + 13]
            v14 = y[r + 14]
            v15 = y[r + 15]
            v16 = y[r + 16]
            v17 = y[r + 17]
            v18 = y[r + 18]
            v19 = y[r + 19]
            v20 = y[r + 20]
            v21 = y[r + 21]
            v22 = y[r + 22]
            v23 = y[r + 23]
            v24 = y[r + 24]
            v25 = y[r + 25]
            v26 = y[r + 26]
            v27 = y[r + 27]
            v28 = y[r + 28]
            v29 = y[r + 29]
            v30 = y[r + 30]
        else:
            v0 = y[r + 0] if 0 <= r + 0 < n else 0.0
            v1 = y[r + 1] if 0 <= r + 1 < n else 0.0
            v2 = y[r + 2] if 0 <= r + 2 < n else 0.0
            v3 = y[r + 3] if 0 <= r + 3 < n else 0.0
            v4 = y[r + 4] if 0 <= r + 4 < n else 0.0
            v5 = y[r + 5] if 0 <= r + 5 < n else 0.0
            v6 = y[r + 6] if 0 <= r + 6 < n else 0.0
            v7 = y[r + 7] if 0 <= r + 7 < n else 0.0
            v8 = y[r + 8] if 0 <= r + 8 < n else 0.0
            v9 = y[r + 9] if 0 <= r + 9 < n else 0.0
            v10 = y[r + 10] if 0 <= r + 10 < n else 0.0
            v11 = y[r + 11] if 0 <= r + 11 < n else 0.0
            v12 = y[r + 12] if 0 <= r + 12 < n else 0.0
            v13 = y[r + 13] if 0 <= r + 13 < n else 0.0
            v14 = y[r + 14] if 0 <= r + 14 < n else 0.0
            v15 = y[r + 15] if 0 <= r + 15 < n else 0.0
            v16 = y[r + 16] if 0 <= r + 16 < n else 0.0
            v17 = y[r + 17] if 0 <= r + 17 < n else 0.0
            v18 = y[r + 18] if 0 <= r + 18 < n else 0.0
            v19 = y[r + 19] if 0 <= r + 19 < n else 0.0
            v20 = y[r + 20] if 0 <= r + 20 < n else 0.0
            v21 = y[r + 21] if 0 <= r + 21 < n else 0.0
            v22 = y[r + 22] if 0 <= r + 22 < n else 0.0
            v23 = y[r + 23] if 0 <= r + 23 < n else 0.0
            v24 = y[r + 24] if 0 <= r + 24 < n else 0.0
            v25 = y[r + 25] if 0 <= r + 25 < n else 0.0
            v26 = y[r + 26] if 0 <= r + 26 < n else 0.0
            v27 = y[r + 27] if 0 <= r + 27 < n else 0.0
            v28 = y[r + 28] if 0 <= r + 28 < n else 0.0
            v29 = y[r + 29] if 0 <= r + 29 < n else 0.0
            v30 = y[r + 30] if 0 <= r + 30 < n else 0.0
        v0, v1 = min(v0, v1), max(v0, v1)
        v2, v3 = min(v2, v3), max(v2, v3)
        v4, v5 = min(v4, v5), max(v4, v5)
        v6, v7 = min(v6, v7), max(v6, v7)
        v8, v9 = min(v8, v9), max(v8, v9)
        v10, v11 = min(v10, v11), max(v10, v11)
        v12, v13 = min(v12, v13), max(v12, v13)
        v14, v15 = min(v14, v15), max(v14, v15)
        v16, v17 = min(v16, v17), max(v16, v17)
        v18, v19 = min(v18, v19), max(v18, v19)
        v20, v21 = min(v20, v21), max(v20, v21)
        v22, v23 = min(v22, v23), max(v22, v23)
        v24, v25 = min(v24, v25), max(v24, v25)
        v26, v27 = min(v26, v27), max(v26, v27)
        v28, v29 = min(v28, v29), max(v28, v29)
        v0, v2 = min(v0, v2), max(v0, v2)
        v1, v3 = min(v1, v3), max(v1, v3)
        v4, v6 = min(v4, v6), max(v4, v6)
        v5, v7 = min(v5, v7), max(v5, v7)
        v8, v10 = min(v8, v10), max(v8, v10)
        v9, v11 = min(v9, v11), max(v9, v11)
        v12, v14 = min(v12, v14), max(v12, v14)
        v13, v15 = min(v13, v15), max(v13, v15)
        v16, v18 = min(v16, v18), max(v16, v18)
        v17, v19 = min(v17, v19), max(v17, v19)
        v20, v22 = min(v20, v22), max(v20, v22)
        v21, v23 = min(v21, v23), max(v21, v23)
        v24, v26 = min(v24, v26), max(v24, v26)
        v25, v27 = min(v25, v27), max(v25, v27)
        v28, v30 = min(v28, v30), max(v28, v30)
        v1, v2 = min(v1, v2), max(v1, v2)
        v5, v6 = min(v5, v6), max(v5, v6)
        v9, v10 = min(v9, v10), max(v9, v10)
        v13, v14 = min(v13, v14), max(v13, v14)
        v17, v18 = min(v17, v18), max(v17, v18)
        v21, v22 = min(v21, v22), max(v21, v22)
        v25, v26 = min(v25, v26), max(v25, v26)
        v29, v30 = min(v29, v30), max(v29, v30)
        v0, v4 = min(v0, v4), max(v0, v4)
        v1, v5 = min(v1, v5), max(v1, v5)
        v2, v6 = min(v2, v6), max(v2, v6)
        v3, v7 = min(v3, v7), max(v3, v7)
        v8, v12 = min(v8, v12), max(v8, v12)
        v9, v13 = min(v9, v13), max(v9, v13)
        v10, v14 = min(v10, v14), max(v10, v14)
        v11, v15 = min(v11, v15), max(v11, v15)
        v16, v20 = min(v16, v20), max(v16, v20)
        v17, v21 = min(v17, v21), max(v17, v21)
        v18, v22 = min(v18, v22), max(v18, v22)
        v19, v23 = min(v19, v23), max(v19, v23)
        v24, v28 = min(v24, v28), max(v24, v28)
        v25, v29 = min(v25, v29), max(v25, v29)
        v26, v30 = min(v26, v30), max(v26, v30)
        v2, v4 = min(v2, v4), max(v2, v4)
        v3, v5 = min(v3, v5), max(v3, v5)
        v10, v12 = min(v10, v12), max(v10, v12)
        v11, v13 = min(v11, v13), max(v11, v13)
        v18, v20 = min(v18, v20), max(v18, v20)
        v19, v21 = min(v19, v21), max(v19, v21)
        v26, v28 = min(v26, v28), max(v26, v28)
        v27, v29 = min(v27, v29), max(v27, v29)
        v1, v2 = min(v1, v2), max(v1, v2)
        v3, v4 = min(v3, v4), max(v3, v4)
        v5, v6 = min(v5, v6), max(v5, v6)
        v9, v10 = min(v9, v10), max(v9, v10)
        v11, v12 = min(v11, v12), max(v11, v12)
        v13, v14 = min(v13, v14), max(v13, v14)
        v17, v18 = min(v17, v18), max(v17, v18)
        v19, v20 = min(v19, v20), max(v19, v20)
        v21, v22 = min(v21, v22), max(v21, v22)
        v25, v26 = min(v25, v26), max(v25, v26)
        v27, v28 = min(v27, v28), max(v27, v28)
        v29, v30 = min(v29, v30), max(v29, v30)
        v0, v8 = min(v0, v8), max(v0, v8)
        v1, v9 = min(v1, v9), max(v1, v9)
        v2, v10 = min(v2, v10), max(v2, v10)
        v3, v11 = min(v3, v11), max(v3, v11)
        v4, v12 = min(v4, v12), max(v4, v12)
        v5, v13 = min(v5, v13), max(v5, v13)
        v6, v14 = min(v6, v14), max(v6, v14)
        v7, v15 = min(v7, v15), max(v7, v15)
        v16, v24 = min(v16, v24), max(v16, v24)
        v17, v25 = min(v17, v25), max(v17, v25)
        v18, v26 = min(v18, v26), max(v18, v26)
        v19, v27 = min(v19, v27), max(v19, v27)
        v20, v28 = min(v20, v28), max(v20, v28)
        v21, v29 = min(v21, v29), max(v21, v29)
        v22, v30 = min(v22, v30), max(v22, v30)
        v4, v8 = min(v4, v8), max(v4, v8)
        v5, v9 = min(v5, v9), max(v5, v9)
        v6, v10 = min(v6, v10), max(v6, v10)
        v7, v11 = min(v7, v11), max(v7, v11)
        v20, v24 = min(v20, v24), max(v20, v24)
        v21, v25 = min(v21, v25), max(v21, v25)
        v22, v26 = min(v22, v26), max(v22, v26)
        v23, v27 = min(v23, v27), max(v23, v27)
        v2, v4 = min(v2, v4), max(v2, v4)
        v3, v5 = min(v3, v5), max(v3, v5)
        v6, v8 = min(v6, v8), max(v6, v8)
        v7, v9 = min(v7, v9), max(v7, v9)
        v10, v12 = min(v10, v12), max(v10, v12)
        v11, v13 = min(v11, v13), max(v11, v13)
        v18, v20 = min(v18, v20), max(v18, v20)
        v19, v21 = min(v19, v21), max(v19, v21)
        v22, v24 = min(v22, v24), max(v22, v24)
        v23, v25 = min(v23, v25), max(v23, v25)
        v26, v28 = min(v26, v28), max(v26, v28)
        v27, v29 = min(v27, v29), max(v27, v29)
        v1, v2 = min(v1, v2), max(v1, v2)
        v3, v4 = min(v3, v4), max(v3, v4)
        v5, v6 = min(v5, v6), max(v5, v6)
        v7, v8 = min(v7, v8), max(v7, v8)
        v9, v10 = min(v9, v10), max(v9, v10)
        v11, v12 = min(v11, v12), max(v11, v12)
        v13, v14 = min(v13, v14), max(v13, v14)
        v17, v18 = min(v17, v18), max(v17, v18)
        v19, v20 = min(v19, v20), max(v19, v20)
        v21, v22 = min(v21, v22), max(v21, v22)
        v23, v24 = min(v23, v24), max(v23, v24)
        v25, v26 = min(v25, v26), max(v25, v26)
        v27, v28 = min(v27, v28), max(v27, v28)
        v29, v30 = min(v29, v30), max(v29, v30)
        v0, v16 = min(v0, v16), max(v0, v16)
        v1, v17 = min(v1, v17), max(v1, v17)
        v2, v18 = min(v2, v18), max(v2, v18)
        v3, v19 = min(v3, v19), max(v3, v19)
        v4, v20 = min(v4, v20), max(v4, v20)
        v5, v21 = min(v5, v21), max(v5, v21)
        v6, v22 = min(v6, v22), max(v6, v22)
        v7, v23 = min(v7, v23), max(v7, v23)
        v8, v24 = min(v8, v24), max(v8, v24)
        v9, v25 = min(v9, v25), max(v9, v25)
        v10, v26 = min(v10, v26), max(v10, v26)
        v11, v27 = min(v11, v27), max(v11, v27)
        v12, v28 = min(v12, v28), max(v12, v28)
        v13, v29 = min(v13, v29), max(v13, v29)
        v14, v30 = min(v14, v30), max(v14, v30)
        v8, v16 = min(v8, v16), max(v8, v16)
        v9, v17 = min(v9, v17), max(v9, v17)
        v10, v18 = min(v10, v18), max(v10, v18)
        v11, v19 = min(v11, v19), max(v11, v19)
        v12, v20 = min(v12, v20), max(v12, v20)
        v13, v21 = min(v13, v21), max(v13, v21)
        v14, v22 = min(v14, v22), max(v14, v22)
        v15, v23 = min(v15, v23), max(v15, v23)
        v12, v16 = min(v12, v16), max(v12, v16)
        v13, v17 = min(v13, v17), max(v13, v17)
        v14, v18 = min(v14, v18), max(v14, v18)
        v15, v19 = min(v15, v19), max(v15, v19)
        v14, v16 = min(v14, v16), max(v14, v16)
        v15, v17 = min(v15, v17), max(v15, v17)
        v15, v16 = min(v15, v16), max(v15, v16)
        out[q] = v15


def medians_at(y: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """PX4's running median of one run (:func:`rinscal.calibration.thermal.baselines.
    px4_median_filter`: 31 samples centred on the row, zeros beyond the ends) at
    rows ``keep`` only.

    Parameters
    ----------
    y : ndarray, shape (n,) [output units]
        One run of one channel, finite.
    keep : ndarray of int, shape (m,)
        Rows, each in ``[0, n)``.

    Returns
    -------
    ndarray, shape (m,) [output units]
    """
    out = np.empty(keep.size)
    if keep.size:
        _medians(np.asarray(y, dtype=np.float64), np.ascontiguousarray(keep, dtype=np.int64), out)
    return out
