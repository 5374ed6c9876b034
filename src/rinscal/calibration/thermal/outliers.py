"""The outlier screen of the features: a sample far from the running median of its channel.

Outliers of the sensor output (e.g. turntable-motor vibration, Section 3 of the paper) are
*masked*, never removed: a running median of each channel within each run, then the robust
spread ``1.4826 · MAD`` of the residuals about it; a sample further than ``threshold``
spreads from the running median is an outlier (:func:`outlier_mask`; the counts per run and
channel in an :class:`OutlierReport`).

A window of many samples (10 s at 100 Hz: 1001) makes the running median the costliest step
of the features (O(n log k)). Above :data:`DECIMATE_FROM` samples per window the screen
(``OutlierConfig.kind = "decimated"``, the default) takes the running median of every
``d``-th sample (``d = k // 64``: a median of about 64 samples, still spanning the window),
interpolates it linearly between those samples, and raises each sample's threshold by the
largest step of those medians about it (more than the interpolation's error, and than the
shift of a median by one sample: on a noiseless drift nothing is flagged, as the running
median flags nothing). Below, it is the running median itself, to the bit.
``docs/calibration.md`` ("The outlier screen") compares the two on the simulated soak and
the real thermal-cycle log.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import pandas as pd

from rinscal.errors import ConfigError

__all__ = ["DECIMATE_FROM", "OutlierConfig", "OutlierReport", "median_interval", "outlier_mask"]


@dataclass(frozen=True)
class OutlierConfig:
    """Outlier masking about a baseline (block or running median) and MAD.

    Parameters
    ----------
    window_s : float [s]
        Length of the median window (converted to an odd number of samples with the run's
        median sampling interval, at least 5).
    threshold : float [-]
        A sample is an outlier when ``|x − baseline| > threshold · 1.4826 · MAD``.
    enabled : bool
        False masks nothing (NaN samples stay masked).
    kind : {"decimated", "running"}
        ``"running"``: the running median of the window about each sample
        (``scipy.ndimage.median_filter``, ends extended by their edge values: the screen
        before issue 39). ``"decimated"`` (default): the same below :data:`DECIMATE_FROM`
        samples per window; above, the running median of every ``d``-th sample,
        interpolated (see the module docstring), about four times cheaper at 100 Hz.
    """

    window_s: float = 10.0
    threshold: float = 6.0
    enabled: bool = True
    kind: Literal["decimated", "running"] = "decimated"

    def __post_init__(self) -> None:
        if not (np.isfinite(self.window_s) and self.window_s > 0):
            raise ConfigError(f"outlier window_s must be positive, got {self.window_s!r}")
        if not (np.isfinite(self.threshold) and self.threshold > 0):
            raise ConfigError(f"outlier threshold must be positive, got {self.threshold!r}")
        if self.kind not in ("decimated", "running"):
            raise ConfigError(f"outlier kind must be 'decimated' or 'running', got {self.kind!r}")


@dataclass(frozen=True)
class OutlierReport:
    """Samples masked per run and channel.

    Attributes
    ----------
    runs : tuple of str
        Run names, in order of first appearance in the log.
    channels : tuple of str
        Channel names.
    removed : ndarray of int, shape (n_runs, n_channels)
        Outliers masked (NaN samples not counted).
    missing : ndarray of int, shape (n_runs, n_channels)
        NaN (dropped) samples.
    samples : ndarray of int, shape (n_runs,)
        Samples per run.
    """

    runs: tuple[str, ...]
    channels: tuple[str, ...]
    removed: np.ndarray
    missing: np.ndarray
    samples: np.ndarray

    def to_frame(self) -> pd.DataFrame:
        """One row per run and channel: ``run, channel, samples, removed, missing``."""
        rows = [
            {
                "run": r,
                "channel": c,
                "samples": int(self.samples[i]),
                "removed": int(self.removed[i, j]),
                "missing": int(self.missing[i, j]),
            }
            for i, r in enumerate(self.runs)
            for j, c in enumerate(self.channels)
        ]
        return pd.DataFrame(rows, columns=["run", "channel", "samples", "removed", "missing"])

    def total(self, channel: str) -> int:
        """Outliers masked in ``channel`` over all runs."""
        return int(self.removed[:, self.channels.index(channel)].sum())


#: Samples × window up to which the running median is computed with numpy.
_NUMPY_MEDIAN_MAX = 2_000_000


def median_interval(t: np.ndarray) -> float:
    """Median sampling interval of one run [s] (1 for a single sample)."""
    return float(np.median(np.diff(t))) if t.size > 1 else 1.0


def _odd_window(t: np.ndarray, window_s: float, dt: float | None = None) -> int:
    dt = median_interval(t) if dt is None else dt
    k = round(window_s / dt) if dt > 0 else 5
    k = max(k, 5)
    return k if k % 2 else k + 1


def _median_filter(y: np.ndarray, size: int) -> np.ndarray:
    """Running median over ``size`` samples, ends extended by their edge value.

    ``scipy.ndimage.median_filter(y, size, mode="nearest")``; a short series is done with
    numpy on the same padded windows (identical values), which spares a small command the
    0.2 s of importing ``scipy.ndimage``.
    """
    if y.size * size <= _NUMPY_MEDIAN_MAX:
        half = size // 2
        padded = np.pad(y, (half, size - 1 - half), mode="edge")
        return np.median(np.lib.stride_tricks.sliding_window_view(padded, size), axis=1)
    from scipy.ndimage import median_filter  # deferred: 0.2 s to import, long series only

    return median_filter(y, size=size, mode="nearest")


#: Samples per window from which the ``decimated`` screen decimates (below: the running
#: median itself).
DECIMATE_FROM = 128
#: Samples of the decimated series per window (about; odd).
_DECIMATED_WINDOW = 64


def _decimated_median(y: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray | float]:
    """Baseline of a series and each sample's allowance for its interpolation error.

    Below :data:`DECIMATE_FROM` samples per window: the running median over ``size``
    samples (:func:`_median_filter`) and no allowance (0). Above: the running median, over
    about :data:`_DECIMATED_WINDOW` samples spanning the same window, of every ``d``-th sample
    (``d = size // 64``, the last sample included), linearly interpolated between them; the
    allowance of a sample between two of them is the largest step of those medians over its
    interval and the two beside it: more than the error of the interpolation (``h² |y''| /
    8`` over ``h`` samples), and than the shift of a median by one sample of the window (an
    outlier in it), which on a noiseless drift would otherwise exceed the spread.
    """
    n = y.size
    d = size // _DECIMATED_WINDOW if size >= DECIMATE_FROM else 1
    if d <= 1 or n < 3 * d:
        return _median_filter(y, size), 0.0
    k = round(size / d)
    k += 1 - k % 2  # odd
    nodes = np.arange(0, n, d)
    if nodes[-1] != n - 1:
        nodes = np.append(nodes, n - 1)
    m = _median_filter(np.ascontiguousarray(y[nodes]), min(k, nodes.size - (1 - nodes.size % 2)))
    # each segment [nodes[j], nodes[j+1]): its start value, slope per sample, and allowance:
    # the largest step of the medians over it and its neighbours
    step_m = np.diff(m)
    big = np.abs(step_m)
    allow_seg = big.copy()
    allow_seg[1:] = np.maximum(allow_seg[1:], big[:-1])
    allow_seg[:-1] = np.maximum(allow_seg[:-1], big[1:])
    slope = step_m / np.diff(nodes)
    full = (nodes.size - 2) * d  # rows in whole segments of d samples; the last is shorter
    base = np.empty(n)
    allow = np.empty(n)
    ramp = np.arange(d, dtype=np.float64)
    body = base[:full].reshape(-1, d)  # m + slope · ramp, written in place
    np.multiply(slope[:-1, None], ramp, out=body)
    body += m[:-2, None]
    allow[:full].reshape(-1, d)[:] = allow_seg[:-1, None]
    base[full:] = m[-2] + slope[-1] * np.arange(n - full, dtype=np.float64)
    allow[full:] = allow_seg[-1]
    return base, allow


def outlier_mask(
    t: np.ndarray, y: np.ndarray, config: OutlierConfig, dt: float | None = None
) -> np.ndarray:
    """Outliers of one run of one or more channels, by running median (decimated above
    :data:`DECIMATE_FROM` samples per window) and MAD.

    Parameters
    ----------
    t : ndarray, shape (n,) [s]
        Time of one run (sets the window length in samples).
    y : ndarray, shape (n,) or (n, m)
        Sensor output; NaN samples are never outliers (they are missing).
    config : OutlierConfig
        Window and threshold.
    dt : float, optional [s]
        :func:`median_interval` of ``t``, when the caller has it already.

    Returns
    -------
    ndarray of bool, same shape as ``y``
        True at outliers.
    """
    y = np.asarray(y, dtype=np.float64)
    y2 = y.reshape(y.shape[0], -1)
    out = np.zeros(y2.shape, dtype=bool)
    if not config.enabled or y2.shape[0] < 5:
        return out.reshape(y.shape)
    k = min(_odd_window(t, config.window_s, dt), y2.shape[0] - (1 - y2.shape[0] % 2))
    for j in range(y2.shape[1]):
        col = y2[:, j]
        ok = np.isfinite(col)
        if ok.sum() < 5:
            continue
        # fill missing samples by the nearest finite one so the running median is defined
        filled = col
        all_ok = bool(ok.all())
        if not all_ok:
            idx = np.flatnonzero(ok)
            near = idx[np.clip(np.searchsorted(idx, np.arange(col.size)), 0, idx.size - 1)]
            filled = col[near]
        if config.kind == "running":
            med, allow = _median_filter(filled, k), 0.0
        else:
            med, allow = _decimated_median(filled, k)
        resid = np.subtract(col, med, out=med)  # the baseline's buffer: a run is long
        np.abs(resid, out=resid)
        kept = resid[ok] if not all_ok else resid.copy()  # a copy: resid is used below
        mad = float(np.median(kept, overwrite_input=True))
        if mad > 0:
            out[:, j] = ok & (resid > config.threshold * 1.4826 * mad + allow)
        else:  # quantised output: at least half the samples equal their running median
            spread = float(np.std(resid[ok]))
            if spread > 0:
                out[:, j] = ok & (resid > config.threshold * spread + allow)
    return out.reshape(y.shape)
