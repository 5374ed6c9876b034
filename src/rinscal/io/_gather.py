"""The compiled message copier the ULog and DataFlash readers share.

Apart from :mod:`rinscal.io.flightinfo` so that numba is loaded by a flight-log reader only,
not by every command that imports the flight-log options.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def _gather(
    buf: np.ndarray, offsets: np.ndarray, skip: int, width: int, out: np.ndarray, sized: bool
) -> int:
    """Copy ``width`` bytes from ``offset + skip`` of each message into rows of ``out``.

    With ``sized`` (ULog), a message whose size field (uint16 at ``offset``) says it is
    shorter than ``skip - 3 + width`` is not copied; a message cut by the end of the file
    never is. The rows copied are packed at the front; returns their number.
    """
    k = 0
    for i in range(offsets.size):
        o = offsets[i]
        a = o + skip
        if a + width > buf.size:
            continue
        if sized and (np.int64(buf[o]) | (np.int64(buf[o + 1]) << 8)) + 3 < skip + width:
            continue
        out[k, :] = buf[a : a + width]
        k += 1
    return k
