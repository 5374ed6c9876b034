"""ArduPilot's moving average at chosen windows of a run only: a numba kernel (private).

``fit --method auto`` keeps every ``k``-th row of a log for its held-out choice, each with
the value of ArduPilot's 2 s moving average centred on that row, computed on the whole run
(:class:`rinscal.calibration.thermal.runs.RowSample`). :func:`window_means_at` gives those
means from the cumulative sums about ``x[0]`` of
:func:`rinscal.calibration.thermal.baselines.moving_average`, added in the same order
(``numpy.cumsum`` adds strictly left to right) and differenced and scaled as it does: the
same numbers to the last bit, in one pass over the run, without its temporaries (the
difference from ``x[0]`` and the sums of every row) or the means of every other window.

Compiled once and cached on disk (``nogil``: the channels' threads run it at once).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["window_means_at"]


@numba.njit(cache=True, nogil=True)
def _window_means(x, w, starts, out):  # pragma: no cover - numba
    """``out[q]`` = ``(c[s + w] − c[s]) / w + x[0]``, ``s = starts[q]`` (increasing), ``c`` the
    cumulative sums of ``x − x[0]`` (``c[0] = 0``), summed left to right in one pass."""
    x0 = x[0]
    m = starts.shape[0]
    at_start = np.empty(m)  # c at each window's start
    c = 0.0  # c[k]
    k = qa = qb = 0  # qa: next window to start, qb: next to end
    while qb < m:
        stop = starts[qb] + w  # the next row where c is needed
        if qa < m and starts[qa] < stop:
            stop = starts[qa]
        for j in range(k, stop):
            c += x[j] - x0
        k = stop
        while qa < m and starts[qa] == k:
            at_start[qa] = c
            qa += 1
        while qb < m and starts[qb] + w == k:
            out[qb] = (c - at_start[qb]) / w + x0
            qb += 1


def window_means_at(x: np.ndarray, w: int, starts: np.ndarray) -> np.ndarray:
    """ArduPilot's moving average of ``x`` (:func:`rinscal.calibration.thermal.baselines.
    moving_average`, window ``w``) at the windows starting at ``starts`` only.

    Parameters
    ----------
    x : ndarray, shape (n,) [any unit]
        One run.
    w : int
        Window [samples], at least 1.
    starts : ndarray of int, shape (m,)
        Increasing, each in ``[0, n − w]``.

    Returns
    -------
    ndarray, shape (m,) [unit of x]
    """
    out = np.empty(starts.size)
    if starts.size:
        _window_means(x, int(w), np.ascontiguousarray(starts, dtype=np.int64), out)
    return out
