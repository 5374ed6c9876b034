"""Windowed least-squares slope of sampled signals: the temperature-rate kernels.

One estimator, two placements of its window. For sample ``i`` at time ``t_i`` the rate is
the slope of the ordinary least-squares line through the samples ``(t_j, x_j)`` of the
window ``S_i``::

    slope_i = Σ_{j∈S_i} (t_j − t̄)(x_j − x̄) / Σ_{j∈S_i} (t_j − t̄)²

* centred (offline): ``S_i = {j : |t_j − t_i| ≤ W/2}``
* causal (real time): ``S_i = {j ≤ i : t_i − W ≤ t_j}``

For uniform sampling with ``W`` a multiple of the interval, the causal rate at ``t_i`` is
exactly the centred rate at ``t_i − W/2``; both are exact for a straight line. A window
holding fewer than two samples (the first sample of a run) gives a rate of 0. Near the ends
of a run the centred window is truncated (one-sided), never extended into another run.

The sums are kept as running sums about an *anchor* (the oldest sample of the window when
the sums were last rebuilt), so the per-sample cost is O(1) while cancellation stays small:
the sums are rebuilt from scratch whenever the number of add/remove operations since the
last rebuild exceeds twice the window length (amortised O(1)). The causal kernel is a state
machine over a ring buffer: the batch path feeds a whole run at once, the streaming path one
sample at a time, through the *same* compiled function, so both give bit-identical rates.

Several series sharing one time axis (the inner temperatures of six sensors) are processed
together: ``x`` has shape (n, m).
"""

from __future__ import annotations

import numba
import numpy as np

# istate layout (int64): head, count, ops since rebuild
_HEAD, _CNT, _OPS = 0, 1, 2
# tstate layout (float64), time sums about the anchor: anchor_t, s1 = Σ(t−ta), s2 = Σ(t−ta)²
_TA, _S1, _S2 = 0, 1, 2
#: Minimum number of operations between two rebuilds of the running sums.
_MIN_OPS = 16


@numba.njit(cache=True, nogil=True)
def _rebuild(ring_t, ring_x, istate, tstate, xstate):  # pragma: no cover - numba
    """Recompute every running sum from the samples in the ring, about a new anchor."""
    cap = ring_t.shape[0]
    m = ring_x.shape[1]
    head = istate[_HEAD]
    cnt = istate[_CNT]
    ta = ring_t[head]
    tstate[_TA] = ta
    s1 = 0.0
    s2 = 0.0
    for k in range(m):
        xstate[k, 0] = ring_x[head, k]
        xstate[k, 1] = 0.0
        xstate[k, 2] = 0.0
    for q in range(cnt):
        j = (head + q) % cap
        dt = ring_t[j] - ta
        s1 += dt
        s2 += dt * dt
        for k in range(m):
            dx = ring_x[j, k] - xstate[k, 0]
            xstate[k, 1] += dx
            xstate[k, 2] += dt * dx
    tstate[_S1] = s1
    tstate[_S2] = s2
    istate[_OPS] = 0


@numba.njit(cache=True, nogil=True)
def _slope(cnt, tstate, xstate, out_row):  # pragma: no cover - numba
    m = xstate.shape[0]
    n = float(cnt)
    den = n * tstate[_S2] - tstate[_S1] * tstate[_S1]
    if cnt < 2 or not den > 0.0:
        for k in range(m):
            out_row[k] = 0.0
        return
    for k in range(m):
        out_row[k] = (n * xstate[k, 2] - tstate[_S1] * xstate[k, 1]) / den


@numba.njit(cache=True, nogil=True)
def causal_update(t, x, window, ring_t, ring_x, istate, tstate, xstate, out):  # pragma: no cover
    """Advance the causal slope state machine over new samples.

    Parameters
    ----------
    t : ndarray, shape (k,) [s]
        New sample times, strictly increasing and later than any sample already fed.
    x : ndarray, shape (k, m)
        New samples of the ``m`` series.
    window : float [s]
        Window length ``W``.
    ring_t, ring_x : ndarray, shapes (cap,), (cap, m)
        Ring buffer of the window's samples.
    istate : ndarray of int64, shape (3,)
        Head index, sample count, operations since the last rebuild.
    tstate : ndarray, shape (3,)
        Anchor time and time sums.
    xstate : ndarray, shape (m, 3)
        Per series: anchor value, Σ(x − xa), Σ(t − ta)(x − xa).
    out : ndarray, shape (k, m) [unit of x per s]
        Receives the slopes.

    Returns
    -------
    int
        Number of samples consumed; less than ``k`` when the ring is full (the caller grows
        it and calls again with the rest).
    """
    cap = ring_t.shape[0]
    m = x.shape[1]
    for i in range(t.shape[0]):
        ti = t[i]
        head = istate[_HEAD]
        cnt = istate[_CNT]
        # evict samples that left the window [ti - W, ti]
        lo = ti - window
        while cnt > 0 and ring_t[head] < lo:
            dt = ring_t[head] - tstate[_TA]
            tstate[_S1] -= dt
            tstate[_S2] -= dt * dt
            for k in range(m):
                dx = ring_x[head, k] - xstate[k, 0]
                xstate[k, 1] -= dx
                xstate[k, 2] -= dt * dx
            head = (head + 1) % cap
            cnt -= 1
            istate[_OPS] += 1
        istate[_HEAD] = head
        istate[_CNT] = cnt
        if cnt == cap:
            return i
        j = (head + cnt) % cap
        ring_t[j] = ti
        for k in range(m):
            ring_x[j, k] = x[i, k]
        cnt += 1
        istate[_CNT] = cnt
        if cnt == 1:
            _rebuild(ring_t, ring_x, istate, tstate, xstate)
        else:
            dt = ti - tstate[_TA]
            tstate[_S1] += dt
            tstate[_S2] += dt * dt
            for k in range(m):
                dx = x[i, k] - xstate[k, 0]
                xstate[k, 1] += dx
                xstate[k, 2] += dt * dx
            istate[_OPS] += 1
            if istate[_OPS] > max(2 * cnt, _MIN_OPS):
                _rebuild(ring_t, ring_x, istate, tstate, xstate)
        _slope(cnt, tstate, xstate, out[i])
    return t.shape[0]


@numba.njit(cache=True, nogil=True)
def centred_slope(t, x, half_window, out):  # pragma: no cover - numba
    """Centred windowed least-squares slope over one run.

    Parameters
    ----------
    t : ndarray, shape (n,) [s]
        Strictly increasing sample times of one run.
    x : ndarray, shape (n, m)
        Samples of ``m`` series.
    half_window : float [s]
        Half the window length, ``W/2``.
    out : ndarray, shape (n, m) [unit of x per s]
        Receives the slopes.
    """
    n = t.shape[0]
    m = x.shape[1]
    # the window [lo, hi) of indices, with running sums about the anchor index `anchor`
    lo = 0
    hi = 0
    anchor = 0
    ops = 0
    s1 = 0.0
    s2 = 0.0
    sx = np.zeros(m)
    stx = np.zeros(m)
    for i in range(n):
        ti = t[i]
        while hi < n and t[hi] <= ti + half_window:
            dt = t[hi] - t[anchor]
            s1 += dt
            s2 += dt * dt
            for k in range(m):
                dx = x[hi, k] - x[anchor, k]
                sx[k] += dx
                stx[k] += dt * dx
            hi += 1
            ops += 1
        while t[lo] < ti - half_window:
            dt = t[lo] - t[anchor]
            s1 -= dt
            s2 -= dt * dt
            for k in range(m):
                dx = x[lo, k] - x[anchor, k]
                sx[k] -= dx
                stx[k] -= dt * dx
            lo += 1
            ops += 1
        cnt = hi - lo
        if ops > max(2 * cnt, _MIN_OPS):
            anchor = lo
            s1 = 0.0
            s2 = 0.0
            for k in range(m):
                sx[k] = 0.0
                stx[k] = 0.0
            for j in range(lo, hi):
                dt = t[j] - t[anchor]
                s1 += dt
                s2 += dt * dt
                for k in range(m):
                    dx = x[j, k] - x[anchor, k]
                    sx[k] += dx
                    stx[k] += dt * dx
            ops = 0
        nn = float(cnt)
        den = nn * s2 - s1 * s1
        if cnt < 2 or not den > 0.0:
            for k in range(m):
                out[i, k] = 0.0
        else:
            for k in range(m):
                out[i, k] = (nn * stx[k] - s1 * sx[k]) / den


class CausalSlope:
    """Streaming causal windowed least-squares slope of ``m`` series on one time axis.

    Feeding a whole run at once and feeding it sample by sample give bit-identical slopes
    (the same compiled state machine runs in both cases).

    Parameters
    ----------
    window_s : float [s]
        Window length ``W``.
    n_series : int
        Number of series ``m``.
    capacity : int
        Initial ring capacity [samples]; it grows as needed.
    """

    def __init__(self, window_s: float, n_series: int, capacity: int = 256) -> None:
        self.window_s = float(window_s)
        self.n_series = int(n_series)
        self._ring_t = np.zeros(max(int(capacity), 2))
        self._ring_x = np.zeros((self._ring_t.size, self.n_series))
        self.reset()

    def reset(self) -> None:
        """Forget every sample (start of a new run)."""
        self._istate = np.zeros(3, dtype=np.int64)
        self._tstate = np.zeros(3)
        self._xstate = np.zeros((self.n_series, 3))
        self._last_t = -np.inf

    def _grow(self) -> None:
        cap = self._ring_t.size
        head, cnt = int(self._istate[_HEAD]), int(self._istate[_CNT])
        idx = (head + np.arange(cnt)) % cap
        new_t = np.zeros(2 * cap)
        new_x = np.zeros((2 * cap, self.n_series))
        new_t[:cnt] = self._ring_t[idx]
        new_x[:cnt] = self._ring_x[idx]
        self._ring_t, self._ring_x = new_t, new_x
        self._istate[_HEAD] = 0

    def update(self, t: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Feed new samples and return their slopes.

        Parameters
        ----------
        t : ndarray, shape (k,) [s]
            Strictly increasing times, later than every sample fed before.
        x : ndarray, shape (k, m)
            The samples.

        Returns
        -------
        ndarray, shape (k, m) [unit of x per s]
            Causal slope at each new sample.
        """
        t = np.ascontiguousarray(t, dtype=np.float64).reshape(-1)
        x = np.ascontiguousarray(x, dtype=np.float64).reshape(t.size, self.n_series)
        if t.size and (t[0] <= self._last_t or np.any(np.diff(t) <= 0)):
            raise ValueError("sample times must be strictly increasing")
        out = np.empty((t.size, self.n_series))
        done = 0
        while done < t.size:
            k = causal_update(
                t[done:],
                x[done:],
                self.window_s,
                self._ring_t,
                self._ring_x,
                self._istate,
                self._tstate,
                self._xstate,
                out[done:],
            )
            done += k
            if done < t.size:
                self._grow()
        if t.size:
            self._last_t = float(t[-1])
        return out


def window_capacity(t: np.ndarray, window_s: float) -> int:
    """Largest number of samples any causal window ``[t_i − W, t_i]`` of ``t`` holds."""
    first = np.searchsorted(t, t - window_s, side="left")
    return int(np.max(np.arange(t.size) - first + 1)) if t.size else 1


def causal_slope(t: np.ndarray, x: np.ndarray, window_s: float) -> np.ndarray:
    """Causal windowed least-squares slope over one run (batch).

    Parameters
    ----------
    t : ndarray, shape (n,) [s]
        Strictly increasing times of one run.
    x : ndarray, shape (n, m)
        Samples of ``m`` series.
    window_s : float [s]
        Window length ``W``.

    Returns
    -------
    ndarray, shape (n, m) [unit of x per s]
    """
    t = np.ascontiguousarray(t, dtype=np.float64)
    x = np.ascontiguousarray(x, dtype=np.float64).reshape(t.size, -1)
    est = CausalSlope(window_s, x.shape[1], capacity=window_capacity(t, window_s) + 1)
    return est.update(t, x)


def centred_slope_run(t: np.ndarray, x: np.ndarray, window_s: float) -> np.ndarray:
    """Centred windowed least-squares slope over one run (batch).

    Parameters
    ----------
    t : ndarray, shape (n,) [s]
        Strictly increasing times of one run.
    x : ndarray, shape (n, m)
        Samples of ``m`` series.
    window_s : float [s]
        Window length ``W`` (the window is ``[t_i − W/2, t_i + W/2]``).

    Returns
    -------
    ndarray, shape (n, m) [unit of x per s]
    """
    t = np.ascontiguousarray(t, dtype=np.float64)
    x = np.ascontiguousarray(x, dtype=np.float64).reshape(t.size, -1)
    out = np.empty_like(x)
    centred_slope(t, x, 0.5 * float(window_s), out)
    return out


def load_kernel(kind: str = "centred") -> None:
    """Load the compiled kernel of a ``kind`` (``"centred"`` or ``"causal"``) rate now.

    The first call of a kernel in a process loads it from numba's cache (about a second:
    numba's own machinery comes with it); a command calls this while its first run is read
    on another thread, so that the two overlap.
    """
    t = np.arange(3, dtype=np.float64)
    t.flags.writeable = False  # as a log's time column comes (a read-only view): that kernel
    x = np.zeros((3, 1))
    if kind == "causal":
        causal_slope(t, x, 1.0)
    else:
        centred_slope_run(t, x, 1.0)
