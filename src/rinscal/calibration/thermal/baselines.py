"""The field's own thermal fits, re-implemented: PX4 and ArduPilot, as users run them today.

Both fit one cubic in the inner temperature ``T`` [°C] per channel; they differ in how they
prepare the data, where they put the reference temperature and what they keep of the
constant. Both firmwares clamp ``T`` to the calibrated range ``[t_min, t_max]`` before
evaluating. The fitted parameters are the ``px4`` and ``ardupilot`` forms of
:mod:`rinscal.calibration.inference`:
``f = Σ_{k=0..3} coef[k] (clip(T, t_min, t_max) − t_ref)^k`` [output units], and compensation
is ``N' = N − f`` as for every other method. Nothing here is copied from those projects; the
procedures are re-implemented from their documented scripts with numpy/scipy.

PX4 (``Tools/process_sensor_caldata.py`` of PX4/PX4-Autopilot, read at commit ``00f5c319``)
    Per sensor instance, for gyroscopes (``sensor_gyro``) and accelerometers
    (``sensor_accel``):

    1. ``TMIN``/``TMAX`` = min/max of the raw (unfiltered) temperature samples,
       ``TREF = 0.5 (TMIN + TMAX)``; ``T_rel = T − TREF``.
    2. The output of each axis (not the temperature) goes through
       ``scipy.signal.medfilt(data, 31)``: a centred 31-sample running median, the log
       zero-padded at both ends (``median_filter``).
    3. Accelerometers only: the median of the filtered output is subtracted
       (``correction_x = x − np.median(x)``). Gyros keep their level.
    4. ``resampleWithDeltaX``: ``[min T_rel, max T_rel]`` is cut into 2000 equal bins
       (``interval = (max − min) / 2000``; a sample goes to ``int((T_rel − min) / interval)``,
       the maximum to the last bin); each non-empty bin becomes one point, the mean ``T_rel``
       and the mean output of its samples; empty bins are dropped. (``--no_resample`` skips
       this and fits every sample: ``resample=False``.)
    5. ``np.polyfit(T_rel_bins, output_bins, 3)``: ``TC_*_X3 .. X0`` are its coefficients from
       the highest power down, so ``X0`` is the fitted constant (for accelerometers the
       constant of the median-removed output).

    The firmware (``src/modules/temperature_compensation/TemperatureCompensation.cpp``,
    ``calc_thermal_offsets_3D``) clamps ``T`` to ``[TMIN, TMAX]``, computes
    ``offset = X0 + X1 d + X2 d² + X3 d³`` with ``d = T_clamped − TREF`` and subtracts it from
    the raw output. Our ``px4`` parameters are ``TREF, TMIN, TMAX`` and
    ``coef = [X0, X1, X2, X3]``, except that for accelerometers the median removed in step 3
    is added back to ``coef[0]`` (the script's ``X0 = coef[0] − median``): the model carries
    the training level like every other method of ours, so that compensation ``N − (f − r)``
    and the exports, which subtract the static reference ``r`` (gravity), remove it once,
    not twice.

ArduPilot (``Tools/scripts/tempcal_IMU.py`` of ArduPilot/ardupilot, read at commit
``d4209711``; ``libraries/AP_InertialSensor/AP_InertialSensor_tempcal.cpp``)
    1. ``IMUData.FilterArray`` with ``width_s = 2``: the window is
       ``int(nsamples / nseconds) * 2`` samples (``nseconds = time[-1] − time[0]``); when it
       exceeds one sample, the temperature, every axis and the time go through a trailing
       moving average (``moving_average``: cumulative sums, only complete windows kept, so
       ``n − w + 1`` points remain).
    2. ``TMIN``/``TMAX`` = min/max of the *smoothed* temperature.
    3. ``np.polyfit(T_smooth − 35, output_smooth, 3)`` (``POLY_ORDER = 3``,
       ``TEMP_REF = 35.0``), a least-squares cubic *with* a constant term; for accelerometers
       an offset (the mean of the smoothed output, or its value at ``INS_ACCn_CALTEMP`` when
       the log has one) is subtracted first, which changes only that constant.
    4. ``Coefficients.param_string`` writes the coefficients of ``(T − 35)^1..3`` (× 1e6) as
       ``INS_TCALn_ACC1..3``/``GYR1..3`` and drops the constant: ArduPilot's separate
       offset calibration holds the level. (The ``.parm`` text rounds ``TMIN``/``TMAX`` to
       0.1 °C and the scaled coefficients to 9 decimals; we keep the unrounded numbers and
       leave the file format to the export.)

    The firmware (``TCal::correct_sensor``, ``TCal::polynomial_eval``) clamps ``T`` (and the
    calibration temperature) to ``[TMIN, TMAX]`` and subtracts the constant-free cubic in
    ``T − 35``. Our ``ardupilot`` parameters keep ``t_ref = 35``, ``t_min``/``t_max`` and
    ``coef[1:]`` as fitted (without the × 1e6), and set ``coef[0]``, which ArduPilot does not
    have, to the mean over the training samples of ``y − Σ_{k=1..3} coef[k] (clip(T) − 35)^k``,
    so that the model carries the training level like every other method of ours.

Several runs (our logs stack cold starts; the tools read one log): every filter runs within
one run, never across a boundary, the ArduPilot window from that run's own sample rate;
everything after the filters (``TMIN``/``TMAX``, the accelerometer median, the bins, the
fit) uses the pooled samples of all runs. Rows whose output ``y`` is NaN (dropped samples) are
removed before filtering, so a filter window spans the remaining samples of its run.
"""

from __future__ import annotations

import itertools
import operator
from typing import Any

import numpy as np

from rinscal.calibration.inference import ARDUPILOT_T_REF, predict_params
from rinscal.calibration.regression import polynomial_fit

__all__ = [
    "ARDUPILOT_WINDOW_S",
    "PX4_MEDIAN_KERNEL",
    "PX4_N_BINS",
    "SENSORS",
    "ardupilot_fit",
    "ardupilot_fit_smoothed",
    "ardupilot_smoothed",
    "ardupilot_window",
    "moving_average",
    "px4_filtered",
    "px4_fit",
    "px4_fit_filtered",
    "px4_median_filter",
    "px4_resample",
    "run_bounds",
]

#: Sensor types: the PX4 fit removes an accelerometer's median, not a gyro's.
SENSORS: tuple[str, ...] = ("gyro", "accel")
#: Length [samples] of PX4's running median (``medfilt(data, 31)``).
PX4_MEDIAN_KERNEL = 31
#: Number of equal temperature bins of PX4's ``resampleWithDeltaX``.
PX4_N_BINS = 2000
#: Width [s] of ArduPilot's moving average (``data.Filter(2)``).
ARDUPILOT_WINDOW_S = 2
_DEGREE = 3


# ----------------------------------------------------------------------------- helpers


def run_bounds(groups: Any, n: int) -> np.ndarray:
    """Boundaries of the contiguous runs of a stacked log.

    Parameters
    ----------
    groups : array_like, shape (n,), or None
        Run code of each row (rows in time order within a run, each run one contiguous
        block); None: one run.
    n : int
        Number of rows.

    Returns
    -------
    ndarray of int, shape (runs + 1,)
        Row ``bounds[i]`` starts run ``i``, which ends before row ``bounds[i + 1]``.

    Raises
    ------
    ValueError
        If ``groups`` has the wrong length or a run is split into several blocks.
    """
    if groups is None:
        return np.array([0, n], dtype=np.intp)
    g = np.asarray(groups)
    if g.ndim != 1 or g.shape[0] != n:
        raise ValueError(f"groups must be 1-D with {n} entries, got shape {g.shape}")
    if n == 0:
        return np.array([0], dtype=np.intp)
    starts = np.concatenate([[0], np.flatnonzero(g[1:] != g[:-1]) + 1])
    if np.unique(g[starts]).size != starts.size:
        raise ValueError("groups: each run must be one contiguous block of rows")
    return np.append(starts, n).astype(np.intp)


def _check_sensor(sensor: Any) -> str:
    if sensor not in SENSORS:
        raise ValueError(f"sensor must be one of {', '.join(SENSORS)}, got {sensor!r}")
    return str(sensor)


def _prepare(
    temp: Any, y: Any, groups: Any, t: Any = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """Arrays as float, runs checked, NaN rows of ``y`` dropped (bounds recomputed)."""
    temp = np.asarray(temp, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    n = temp.shape[0] if temp.ndim == 1 else -1
    if temp.ndim != 1 or y.shape != (n,):
        raise ValueError(
            f"temperature and output must be 1-D of equal length, got {temp.shape}, {y.shape}"
        )
    if not np.all(np.isfinite(temp)):
        raise ValueError("the temperature holds a non-finite value")
    bounds = run_bounds(groups, n)
    keep = ~np.isnan(y)
    if not np.all(np.isfinite(y[keep])):
        raise ValueError("the output holds an infinite value")
    if t is not None:
        t = np.asarray(t, dtype=np.float64)
        if t.shape != (n,):
            raise ValueError(f"t must be 1-D with {n} entries, got shape {t.shape}")
        if not np.all(np.isfinite(t[keep])):
            raise ValueError("the time t holds a non-finite value")
    if not keep.all():
        # kept rows before each old boundary = the new boundary
        kept_before = np.concatenate([[0], np.cumsum(keep)])
        bounds = np.unique(kept_before[bounds])
        temp, y = temp[keep], y[keep]
        t = None if t is None else t[keep]
    if y.size == 0:
        raise ValueError("no finite output sample to fit")
    return temp, y, bounds, t


def _distinct_at_least(x: np.ndarray, m: int) -> bool:
    """Whether ``x`` has at least ``m`` distinct values, as ``np.unique`` counts them: at
    most ``m`` passes that each drop one value, no sort (held-out folds fit often)."""
    rest = np.asarray(x).ravel()
    for _ in range(m):
        if not rest.size:
            return False
        v = rest[0]
        if np.isnan(v):  # np.unique counts every NaN as one value: count exactly
            return bool(np.unique(x).size >= m)
        rest = rest[rest != v]
    return True


def _polyfit3(x: np.ndarray, y: np.ndarray, what: str) -> np.ndarray:
    """``np.polyfit(x, y, 3)`` (:func:`rinscal.calibration.regression.polynomial_fit`, the
    same numbers), refusing fewer than 4 distinct abscissae."""
    if not _distinct_at_least(x, _DEGREE + 1):
        k = np.unique(x).size
        raise ValueError(
            f"a cubic in temperature needs at least {_DEGREE + 1} distinct {what}, got {k}"
        )
    return polynomial_fit(x, y, _DEGREE)


# ----------------------------------------------------------------------------- PX4


def px4_median_filter(y: np.ndarray, kernel: int = PX4_MEDIAN_KERNEL) -> np.ndarray:
    """PX4's ``median_filter``: ``scipy.signal.medfilt(y, kernel)``.

    A centred running median of ``kernel`` (odd) samples; beyond both ends the series is
    padded with zeros, as ``medfilt`` does (so the first and last ``kernel // 2`` outputs
    see zeros). Computed with :func:`scipy.ndimage.median_filter` (``mode="constant"``,
    ``cval=0``), which gives the same numbers faster.

    Parameters
    ----------
    y : ndarray, shape (n,) [output units]
        One run of one channel.
    kernel : int
        Window length [samples], odd.

    Returns
    -------
    ndarray, shape (n,) [output units]
    """
    if kernel < 1 or kernel % 2 == 0:
        raise ValueError(f"kernel must be a positive odd number, got {kernel}")
    y = np.asarray(y, dtype=np.float64)
    if y.size == 0:
        return y.copy()
    # deferred: scipy.ndimage loads in ~0.2 s; only PX4's median filter needs it
    from scipy import ndimage

    return ndimage.median_filter(y, size=kernel, mode="constant", cval=0.0)


def px4_resample(
    x: np.ndarray, y: np.ndarray, n_bins: int = PX4_N_BINS
) -> tuple[np.ndarray, np.ndarray]:
    """PX4's ``resampleWithDeltaX``: bin means over equal bins of ``x``.

    ``[min x, max x]`` is cut into ``n_bins`` bins of width ``(max − min) / n_bins``; a sample
    with ``x < max`` goes to bin ``int((x − min) / width)`` (the last bin if rounding gives
    ``n_bins``), one with ``x = max`` to the last. Each non-empty bin gives the mean ``x``
    and the mean ``y`` of its samples; empty bins are dropped.

    Parameters
    ----------
    x : ndarray, shape (n,) [°C]
        Temperature (PX4 bins ``T − TREF``).
    y : ndarray, shape (n,) [output units]
        Output.
    n_bins : int
        Number of bins.

    Returns
    -------
    x_bins, y_bins : ndarray, shape (m,) [°C], [output units]
        Means of the ``m ≤ n_bins`` non-empty bins, in increasing ``x``.
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    lo, hi = float(np.min(x)), float(np.max(x))
    width = (hi - lo) / n_bins
    idx = np.full(x.shape, n_bins - 1, dtype=np.intp)
    below = x < hi
    idx[below] = np.minimum(((x[below] - lo) / width).astype(np.intp), n_bins - 1)
    count = np.bincount(idx, minlength=n_bins)
    sum_x = np.bincount(idx, weights=x, minlength=n_bins)
    sum_y = np.bincount(idx, weights=y, minlength=n_bins)
    full = count > 0
    return sum_x[full] / count[full], sum_y[full] / count[full]


def px4_fit(
    temp: Any,
    y: Any,
    groups: Any = None,
    *,
    sensor: str = "gyro",
    resample: bool = True,
) -> dict[str, Any]:
    """Fit one channel as PX4's ``process_sensor_caldata.py`` does (see the module docstring).

    Parameters
    ----------
    temp : array_like, shape (n,) [°C]
        Inner temperature.
    y : array_like, shape (n,) [output units]
        Raw output of one channel; NaN rows are dropped before filtering.
    groups : array_like, shape (n,), optional
        Run code of each row (runs contiguous, rows in time order); None: one run. The
        median filter runs within each run.
    sensor : {"gyro", "accel"}
        ``"accel"`` subtracts the median of the filtered output before binning.
    resample : bool
        Fit the 2000 bin means (the script's default) or, False, every filtered sample
        (``--no_resample``).

    Returns
    -------
    dict
        ``px4`` parameters: ``t_ref`` = TREF, ``t_min`` = TMIN, ``t_max`` = TMAX [°C],
        ``coef`` = ``[X0, X1, X2, X3]`` [output units / °C^k]; for ``"accel"`` the median
        removed before the fit is added back to ``coef[0]`` (the training level).

    Raises
    ------
    ValueError
        On bad input, or fewer than 4 distinct temperatures (bins) to fit a cubic.
    """
    sensor = _check_sensor(sensor)
    temp, yf = px4_filtered(temp, y, groups)
    return px4_fit_filtered(temp, yf, sensor=sensor, resample=resample)


def px4_filtered(temp: Any, y: Any, groups: Any = None) -> tuple[np.ndarray, np.ndarray]:
    """The first step of :func:`px4_fit`: NaN rows dropped, the 31-sample median per run.

    Parameters
    ----------
    temp : array_like, shape (n,) [°C]
        Inner temperature.
    y : array_like, shape (n,) [output units]
        Raw output of one channel.
    groups : array_like, shape (n,), optional
        Run code of each row; None: one run.

    Returns
    -------
    temp : ndarray [°C]
        Temperatures of the kept rows.
    yf : ndarray [output units]
        Their median-filtered output.
    """
    temp, y, bounds, _ = _prepare(temp, y, groups)
    yf = np.concatenate([px4_median_filter(y[a:b]) for a, b in itertools.pairwise(bounds)])
    return temp, yf


def px4_fit_filtered(
    temp: np.ndarray, yf: np.ndarray, *, sensor: str = "gyro", resample: bool = True
) -> dict[str, Any]:
    """The rest of :func:`px4_fit` on filtered samples (:func:`px4_filtered`).

    Parameters
    ----------
    temp : ndarray, shape (n,) [°C]
        Temperatures.
    yf : ndarray, shape (n,) [output units]
        Median-filtered output.
    sensor : {"gyro", "accel"}
        ``"accel"`` subtracts the median of ``yf`` before the fit and adds it back to
        ``coef[0]``.
    resample : bool
        Fit the 2000 bin means, or every sample.

    Returns
    -------
    dict
        ``px4`` parameters (see :func:`px4_fit`).
    """
    sensor = _check_sensor(sensor)
    t_min, t_max = float(np.min(temp)), float(np.max(temp))
    t_ref = 0.5 * (t_min + t_max)
    t_rel = temp - t_ref
    level = float(np.median(yf)) if sensor == "accel" else 0.0
    yf = yf - level
    if resample:
        if not t_max > t_min:
            raise ValueError(f"the temperature range is empty (all samples at {t_min} °C)")
        xb, yb = px4_resample(t_rel, yf)
        what = "temperature bins"
    else:
        xb, yb = t_rel, yf
        what = "temperatures"
    c = _polyfit3(xb, yb, what)
    coef = [float(v) for v in c[::-1]]
    coef[0] += level  # the model carries the training level, as every other method's does
    return {"method": "px4", "t_ref": t_ref, "t_min": t_min, "t_max": t_max, "coef": coef}


# ----------------------------------------------------------------------------- ArduPilot


def ardupilot_window(t: np.ndarray, window_s: int = ARDUPILOT_WINDOW_S) -> int:
    """ArduPilot's moving-average length of one run: ``int(nsamples / nseconds) * window_s``.

    Parameters
    ----------
    t : ndarray, shape (n,) [s]
        Sample times of one run, increasing; ``nseconds = t[-1] − t[0]``.
    window_s : int
        Width [s] (2 in ``tempcal_IMU.py``).

    Returns
    -------
    int
        Window [samples]; the tool smooths only when it exceeds 1.
    """
    t = np.asarray(t, dtype=np.float64)
    span = float(t[-1] - t[0])
    if not span > 0:
        raise ValueError(f"time must increase within a run (span {span} s over {t.size} samples)")
    return int(t.size / span) * int(window_s)


def moving_average(x: np.ndarray, w: int) -> np.ndarray:
    """ArduPilot's ``moving_average``: means of the complete windows of ``w`` samples.

    ``out[i] = mean(x[i : i + w])`` for ``i = 0 .. n − w`` (``n − w + 1`` values; none when
    ``n < w``). Cumulative sums about ``x[0]`` (the tool sums the raw values; the result
    differs only by rounding).

    Parameters
    ----------
    x : ndarray, shape (n,) [any unit]
        Series.
    w : int
        Window [samples], at least 1.

    Returns
    -------
    ndarray, shape (max(n − w + 1, 0),) [unit of x]
    """
    x = np.asarray(x, dtype=np.float64)
    if x.size < w:
        return np.zeros(0)
    x0 = x[0]
    c = np.concatenate([[0.0], np.cumsum(x - x0)])
    return (c[w:] - c[:-w]) / w + x0


def ardupilot_fit(
    temp: Any,
    y: Any,
    t: Any,
    groups: Any = None,
    *,
    sensor: str = "gyro",
    window_s: int = ARDUPILOT_WINDOW_S,
) -> dict[str, Any]:
    """Fit one channel as ArduPilot's ``tempcal_IMU.py`` does (see the module docstring).

    Parameters
    ----------
    temp : array_like, shape (n,) [°C]
        Inner temperature.
    y : array_like, shape (n,) [output units]
        Raw output of one channel; NaN rows are dropped before smoothing.
    t : array_like, shape (n,) [s]
        Time since each run's power-on, increasing within a run: sets the window.
    groups : array_like, shape (n,), optional
        Run code of each row (runs contiguous, rows in time order); None: one run. Each run
        is smoothed alone with its own window; a run of one sample, or shorter than its
        window, leaves no smoothed point.
    sensor : {"gyro", "accel"}
        ``"accel"`` subtracts the mean smoothed output before the fit, as the script does
        without a logged calibration temperature; it changes only the dropped constant.
    window_s : int
        Moving-average width [s] (2).

    Returns
    -------
    dict
        ``ardupilot`` parameters: ``t_ref`` = 35 [°C], ``t_min``/``t_max`` [°C] (range of the
        smoothed temperature), ``coef`` [output units / °C^k]: ``coef[1:]`` the fitted
        coefficients of ``(T − 35)^1..3``, ``coef[0]`` the mean over the training rows of
        ``y − Σ_{k≥1} coef[k] (clip(T, t_min, t_max) − 35)^k``.

    Raises
    ------
    ValueError
        On bad input, or fewer than 4 distinct smoothed temperatures.
    """
    sensor = _check_sensor(sensor)
    try:
        w_s = operator.index(window_s)
    except TypeError:
        w_s = 0
    if w_s < 1:
        raise ValueError(f"window_s must be a positive whole number of seconds, got {window_s}")
    if t is None:
        raise ValueError(
            "the ArduPilot fit smooths over 2 s: pass t, the time [s] since each run's power-on"
        )
    t_s, y_s, temp, y, _ = ardupilot_smoothed(temp, y, t, groups, window_s=w_s)
    return ardupilot_fit_smoothed(t_s, y_s, temp, y, sensor=sensor)


def ardupilot_smoothed(
    temp: Any, y: Any, t: Any, groups: Any = None, *, window_s: int = ARDUPILOT_WINDOW_S
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The first step of :func:`ardupilot_fit`: the 2 s moving average of each run.

    Parameters
    ----------
    temp, y, t, groups
        As for :func:`ardupilot_fit`.
    window_s : int
        Moving-average width [s].

    Returns
    -------
    t_s, y_s : ndarray
        Smoothed temperature [°C] and output (complete windows of every run).
    temp, y : ndarray
        The kept (non-NaN) rows, for the constant term.
    rows : ndarray of int
        For each smoothed sample, the kept row at the middle of its window.
    """
    temp, y, bounds, tt = _prepare(temp, y, groups, t)
    if tt is None:  # pragma: no cover - _prepare returns t when given one
        raise ValueError("t is missing")
    w_s = int(window_s)
    ts, ys, rows = [], [], []
    for a, b in itertools.pairwise(bounds):
        if b - a < 2:
            continue
        w = ardupilot_window(tt[a:b], w_s)
        if w > 1:
            ts.append(moving_average(temp[a:b], w))
            ys.append(moving_average(y[a:b], w))
            rows.append(a + w // 2 + np.arange(ts[-1].size))
        else:
            ts.append(temp[a:b])
            ys.append(y[a:b])
            rows.append(np.arange(a, b))
    if not ts or sum(v.size for v in ts) == 0:
        raise ValueError("no run is longer than its moving-average window")
    return np.concatenate(ts), np.concatenate(ys), temp, y, np.concatenate(rows)


def ardupilot_fit_smoothed(
    t_s: np.ndarray, y_s: np.ndarray, temp: np.ndarray, y: np.ndarray, *, sensor: str = "gyro"
) -> dict[str, Any]:
    """The rest of :func:`ardupilot_fit` on smoothed samples (:func:`ardupilot_smoothed`).

    Parameters
    ----------
    t_s, y_s : ndarray
        Smoothed temperature [°C] and output.
    temp, y : ndarray
        Raw rows [°C, output units] for the constant term ``coef[0]``.
    sensor : {"gyro", "accel"}
        ``"accel"`` subtracts the mean smoothed output (only the dropped constant changes).

    Returns
    -------
    dict
        ``ardupilot`` parameters (see :func:`ardupilot_fit`).
    """
    sensor = _check_sensor(sensor)
    t_min, t_max = float(np.min(t_s)), float(np.max(t_s))
    if sensor == "accel":
        y_s = y_s - np.mean(y_s)
    c = _polyfit3(t_s - ARDUPILOT_T_REF, y_s, "smoothed temperatures")
    params: dict[str, Any] = {
        "method": "ardupilot",
        "t_ref": ARDUPILOT_T_REF,
        "t_min": t_min,
        "t_max": t_max,
        "coef": [0.0, float(c[2]), float(c[1]), float(c[0])],
    }
    params["coef"][0] = float(np.mean(y - predict_params(params, temp[:, None])))
    return params


# ----------------------------------------------------------------------------- estimators
