"""ArduPilot's moving average at chosen windows of a run only: a numba kernel (private).

``fit --method auto`` keeps every ``k``-th row of a log for its held-out choice, each with
the value of ArduPilot's 2 s moving average centred on that row, computed on the whole run
(:class:`rinscal.calibration.thermal.runs.RowSample`). :func:`window_means_at` gives those
means, of the temperature and of the output in the same pass, from the cumulative sums about
``x[0]`` of :func:`rinscal.calibration.thermal.baselines.moving_average`, added in the same order
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
def _window_means(x, y, w, starts, out_x, out_y):  # pragma: no cover - numba
    """``out_x[q]`` = ``(c[s + w] − c[s]) / w + x[0]``, ``s = starts[q]`` (increasing), ``c``
    the cumulative sums of ``x − x[0]`` (``c[0] = 0``), summed left to right in one pass;
    the same for ``y`` in the same pass (two independent sums: twice as fast as two passes)."""
    x0, y0 = x[0], y[0]
    m = starts.shape[0]
    at_x = np.empty(m)  # c at each window's start
    at_y = np.empty(m)
    cx = cy = 0.0  # c[k]
    k = qa = qb = 0  # qa: next window to start, qb: next to end
    while qb < m:
        stop = starts[qb] + w  # the next row where c is needed
        if qa < m and starts[qa] < stop:
            stop = starts[qa]
        for j in range(k, stop):
            cx += x[j] - x0
            cy += y[j] - y0
        k = stop
        while qa < m and starts[qa] == k:
            at_x[qa] = cx
            at_y[qa] = cy
            qa += 1
        while qb < m and starts[qb] + w == k:
            out_x[qb] = (cx - at_x[qb]) / w + x0
            out_y[qb] = (cy - at_y[qb]) / w + y0
            qb += 1


def window_means_at(
    x: np.ndarray, y: np.ndarray, w: int, starts: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """ArduPilot's moving average of ``x`` and of ``y`` (:func:`rinscal.calibration.thermal.
    baselines.moving_average`, window ``w``) at the windows starting at ``starts`` only.

    Parameters
    ----------
    x, y : ndarray, shape (n,) [any unit]
        Two series of one run (temperature and output).
    w : int
        Window [samples], at least 1.
    starts : ndarray of int, shape (m,)
        Increasing, each in ``[0, n − w]``.

    Returns
    -------
    (ndarray, ndarray), each of shape (m,) [unit of x, unit of y]
    """
    out_x, out_y = np.empty(starts.size), np.empty(starts.size)
    if starts.size:
        _window_means(x, y, int(w), np.ascontiguousarray(starts, dtype=np.int64), out_x, out_y)
    return out_x, out_y
