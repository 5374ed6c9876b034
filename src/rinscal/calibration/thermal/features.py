"""Model inputs built per run: inner temperature, its rate, the inside-outside gradient.

For each sensor channel ``c`` and each sample of a calibration log the features are

* ``T``  — the inner temperature of the sensor [°C] (``temp_<c>``, or the shared ``temp_in``),
* ``Ṫ``  — its rate [°C/min], the slope of a least-squares line through the temperature
  samples of a window of ``window_s`` seconds (centred for offline fitting, causal for real
  time; see :mod:`rinscal.calibration.thermal.rate`), and
* ``ΔT`` — the gradient ``T − temp_out`` [°C] between the sensor and the package surface
  (absent, with a :class:`MissingGradientWarning`, when the log has no ``temp_out``).

Features are computed run by run, never across a run boundary (the rate needs neighbouring
samples of the *same* recording). Outliers of the sensor output (e.g. turntable-motor
vibration, Section 3 of the paper) are *masked*, never removed
(:mod:`rinscal.calibration.thermal.outliers`); the count per run and channel is reported in
an :class:`~rinscal.calibration.thermal.outliers.OutlierReport`.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pandas as pd

from rinscal.calibration.thermal.outliers import (
    OutlierConfig,
    OutlierReport,
    median_interval,
    outlier_mask,
)
from rinscal.errors import ConfigError, LogError
from rinscal.schema import CHAMBER, CHANNELS, RUN, TEMP_OUT, TIME, temperature_column
from rinscal.units import MIN_TO_S

__all__ = [
    "FEATURE_NAMES",
    "DerivativeConfig",
    "Features",
    "LogColumns",
    "MissingGradientWarning",
    "OutlierConfig",
    "OutlierReport",
    "build_features",
    "channel_matrix",
    "column_rates",
    "features_from_columns",
    "gradient_choice",
    "log_columns",
    "outlier_mask",
    "run_features",
    "run_index",
    "run_slices",
    "set_points",
    "temperature_rate",
]

#: Names of the model inputs, in the column order of every feature matrix.
FEATURE_NAMES: tuple[str, str, str] = ("T", "Tdot", "dT")
#: Units of the model inputs, in :data:`FEATURE_NAMES` order.
FEATURE_UNITS: tuple[str, str, str] = ("degC", "degC/min", "degC")


class MissingGradientWarning(UserWarning):
    """The log has no outer temperature: the gradient feature ΔT drops out."""


@dataclass(frozen=True)
class DerivativeConfig:
    """How the temperature rate is estimated.

    Parameters
    ----------
    window_s : float [s]
        Length ``W`` of the least-squares window.
    kind : {"centred", "causal"}
        ``"centred"``: window ``[t − W/2, t + W/2]`` (offline, no lag). ``"causal"``: window
        ``[t − W, t]`` (real time; lags the centred estimate by ``W/2``).
    """

    window_s: float = 60.0
    kind: Literal["centred", "causal"] = "centred"

    def __post_init__(self) -> None:
        if not (np.isfinite(self.window_s) and self.window_s > 0):
            raise ConfigError(
                f"derivative window_s must be a positive number of seconds, got {self.window_s!r}"
            )
        if self.kind not in ("centred", "causal"):
            raise ConfigError(f"derivative kind must be 'centred' or 'causal', got {self.kind!r}")


@dataclass(frozen=True)
class Features:
    """Model inputs and fitting masks of a log, row for row.

    Attributes
    ----------
    channels : tuple of str
        Channels, the column order of the (n, m) arrays.
    temp : ndarray, shape (n, m) [°C]
        Inner temperature ``T`` per channel.
    rate : ndarray, shape (n, m) [°C/min]
        Temperature rate ``Ṫ``.
    grad : ndarray, shape (n, m) [°C] or None
        Gradient ``ΔT = T − temp_out``; None when the log has no ``temp_out``.
    output : ndarray, shape (n, m) [log units]
        The sensor output, NaN where dropped.
    inlier : ndarray of bool, shape (n, m)
        True where a sample may be used for fitting (finite and not an outlier).
    run_codes : ndarray of int, shape (n,)
        Index into ``runs`` of each row.
    runs : tuple of str
        Run names in order of first appearance.
    time_s : ndarray, shape (n,) [s]
        Time since the run's power-on.
    derivative : DerivativeConfig
        How ``rate`` was computed.
    report : OutlierReport
        Outliers masked.
    """

    channels: tuple[str, ...]
    temp: np.ndarray
    rate: np.ndarray
    grad: np.ndarray | None
    output: np.ndarray
    inlier: np.ndarray
    run_codes: np.ndarray
    runs: tuple[str, ...]
    time_s: np.ndarray
    derivative: DerivativeConfig
    report: OutlierReport

    @property
    def has_gradient(self) -> bool:
        """Whether the gradient feature is present."""
        return self.grad is not None

    @property
    def n_features(self) -> int:
        """Number of model inputs: 3 with the gradient, 2 without."""
        return 3 if self.grad is not None else 2

    def matrix(self, channel: str | int) -> np.ndarray:
        """Feature matrix of one channel.

        Parameters
        ----------
        channel : str or int
            Channel name or index.

        Returns
        -------
        ndarray, shape (n, 2 or 3)
            Columns ``T`` [°C], ``Ṫ`` [°C/min] and, if present, ``ΔT`` [°C].
        """
        j = self._index(channel)
        cols = [self.temp, self.rate] + ([self.grad] if self.grad is not None else [])
        block = self.temp.base
        if (  # one channel's features built as one block (build_features): that block
            isinstance(block, np.ndarray)
            and block.shape == (self.temp.shape[0], len(cols))
            and block.flags.f_contiguous
            and all(
                a.base is block and np.may_share_memory(a, block[:, v]) for v, a in enumerate(cols)
            )
        ):
            x = block.view()
            x.flags.writeable = False  # the features' own arrays
            return x
        # column-major: each input is one contiguous column (fits and checks go by column)
        x = np.empty((self.temp.shape[0], len(cols)), order="F")
        for v, a in enumerate(cols):
            x[:, v] = a[:, j]
        return x

    def usable(self, channel: str | int, x: np.ndarray | None = None) -> np.ndarray:
        """Rows a fit of one channel may use: inliers whose every input is finite.

        ``x`` is the channel's :meth:`matrix` when the caller has it already.
        """
        j = self._index(channel)
        x = self.matrix(j) if x is None else x
        ok = self.inlier[:, j].copy()
        for v in range(x.shape[1]):  # column by column: several times faster than axis=1
            ok &= np.isfinite(x[:, v])
        return ok

    def _index(self, channel: str | int) -> int:
        return self.channels.index(channel) if isinstance(channel, str) else int(channel)


def run_slices(run: pd.Series | np.ndarray) -> tuple[np.ndarray, tuple[str, ...], list[np.ndarray]]:
    """Rows of each run, in log order.

    Parameters
    ----------
    run : Series or ndarray, shape (n,)
        The ``run`` column.

    Returns
    -------
    codes : ndarray of int, shape (n,)
        Run index of each row.
    names : tuple of str
        Run names in order of first appearance.
    rows : list of ndarray of int
        Row indices of each run, increasing.
    """
    # factorize the column as it is (converting Arrow text to Python objects costs seconds)
    codes, uniques = pd.factorize(run if isinstance(run, pd.Series) else pd.Series(run), sort=False)
    codes = codes.astype(np.int64, copy=False)
    if codes.size and np.all(codes[1:] >= codes[:-1]):  # runs one after another: slices
        bounds = np.searchsorted(codes, np.arange(len(uniques) + 1))
        rows = [np.arange(bounds[k], bounds[k + 1]) for k in range(len(uniques))]
    else:
        order = np.argsort(codes, kind="stable")
        bounds = np.searchsorted(codes[order], np.arange(len(uniques) + 1))
        rows = [order[bounds[k] : bounds[k + 1]] for k in range(len(uniques))]
    return codes, tuple(str(u) for u in uniques), rows


def run_index(idx: np.ndarray) -> slice | np.ndarray:
    """How to take the rows ``idx`` of a run (:func:`run_slices`) from a log's arrays: a
    slice where they are one block, the usual case (views, not copies), else ``idx``."""
    if idx.size and idx[-1] - idx[0] + 1 == idx.size:
        return slice(int(idx[0]), int(idx[-1]) + 1)
    return idx


def run_features(feats: Features, k: int, idx: np.ndarray) -> Features:
    """The features of run ``k`` (rows ``idx``) of a log's features."""
    if idx.size == feats.run_codes.size:
        return feats
    r = run_index(idx)
    rep = feats.report
    return dataclasses.replace(
        feats,
        temp=feats.temp[r],
        rate=feats.rate[r],
        grad=None if feats.grad is None else feats.grad[r],
        output=feats.output[r],
        inlier=feats.inlier[r],
        run_codes=np.zeros(idx.size, dtype=np.int64),
        runs=(feats.runs[k],),
        time_s=feats.time_s[r],
        report=dataclasses.replace(
            rep,
            runs=(rep.runs[k],),
            removed=rep.removed[k : k + 1],
            missing=rep.missing[k : k + 1],
            samples=rep.samples[k : k + 1],
        ),
    )


def temperature_rate(t: np.ndarray, temp: np.ndarray, derivative: DerivativeConfig) -> np.ndarray:
    """Temperature rate of one run.

    Parameters
    ----------
    t : ndarray, shape (n,) [s]
        Strictly increasing time of one run.
    temp : ndarray, shape (n,) or (n, m) [°C]
        Temperatures.
    derivative : DerivativeConfig
        Window and kind.

    Returns
    -------
    ndarray, same shape as ``temp`` [°C/min]
    """
    # deferred: rate imports numba (~0.25 s) for its kernels; only a rate needs them
    from rinscal.calibration.thermal.rate import causal_slope, centred_slope_run

    temp = np.asarray(temp, dtype=np.float64)
    x = temp.reshape(temp.shape[0], -1)
    if derivative.kind == "causal":
        slope = causal_slope(t, x, derivative.window_s)
    else:
        slope = centred_slope_run(t, x, derivative.window_s)
    return np.multiply(slope, MIN_TO_S, out=slope).reshape(temp.shape)


def set_points(log: pd.DataFrame, decimals: int = 1) -> np.ndarray | None:
    """Chamber set points of the runs of a log.

    Parameters
    ----------
    log : DataFrame
        Calibration log with a ``chamber_temp`` column.
    decimals : int
        Set points are the per-run medians of ``chamber_temp`` rounded to this many decimals.

    Returns
    -------
    ndarray or None [°C]
        Sorted distinct set points; None if there is no ``chamber_temp`` column.
    """
    if CHAMBER not in log.columns:
        return None
    med = log.groupby(RUN, sort=False)[CHAMBER].median().to_numpy(dtype=float)
    return distinct_points(med, decimals)


def distinct_points(medians: np.ndarray, decimals: int = 1) -> np.ndarray:
    """Sorted distinct values of per-run medians, rounded to ``decimals`` [°C] (NaN dropped)."""
    med = np.asarray(medians, dtype=np.float64)
    return np.unique(np.round(med[np.isfinite(med)], decimals))


@dataclass(frozen=True)
class LogColumns:
    """The columns of a validated log that features are built from, as float64 arrays.

    Read once from the table (:func:`log_columns`; a float64 column is a view, not a copy)
    and then shared: the features of each channel are built from these arrays alone, so
    several threads can build them at once (:func:`features_from_columns`).

    Attributes
    ----------
    time_s : ndarray, shape (n,) [s]
        Time since each run's power-on.
    codes, runs, rows
        The runs, as :func:`run_slices` gives them.
    values : mapping of str to ndarray, shape (n,)
        The channels [log units], their temperature columns [°C] and ``temp_out`` [°C] where
        the log has it, by column name.
    temp_column : mapping of str to str
        Each channel's temperature column.
    """

    time_s: np.ndarray
    codes: np.ndarray
    runs: tuple[str, ...]
    rows: list[np.ndarray]
    values: Mapping[str, np.ndarray]
    temp_column: Mapping[str, str]
    _dt: dict[int, float] = dataclasses.field(default_factory=dict, repr=False, compare=False)

    def interval(self, k: int, t: np.ndarray) -> float:
        """Median sampling interval of run ``k`` (times ``t``) [s], found once for every
        channel's outlier screen."""
        if k not in self._dt:  # two threads may both compute it: the same number
            self._dt[k] = median_interval(t)
        return self._dt[k]

    @property
    def has_temp_out(self) -> bool:
        """Whether the log has the outer temperature ``temp_out``."""
        return TEMP_OUT in self.values


def _require(log: pd.DataFrame, channels: Sequence[str]) -> None:
    for c in (TIME, RUN, *channels):
        if c not in log.columns:
            raise LogError(f"log has no column {c!r}")


def gradient_choice(log: pd.DataFrame, use_gradient: bool | None, warn: bool = True) -> bool:
    """Whether features of ``log`` hold the gradient ΔT: as asked, or (None) where the log has
    ``temp_out`` (``warn``: say so when it has not).

    Raises
    ------
    LogError
        ``use_gradient`` True and no ``temp_out`` column.

    Warns
    -----
    MissingGradientWarning
        ``use_gradient`` None and no ``temp_out`` column.
    """
    has_out = TEMP_OUT in log.columns
    if use_gradient is True and not has_out:
        raise LogError(f"log has no {TEMP_OUT!r} column, needed for the gradient feature ΔT")
    if use_gradient is None:
        if warn and not has_out:
            warnings.warn(
                f"log has no {TEMP_OUT!r} column: the gradient feature ΔT drops out; models use "
                "T and dT/dt only",
                MissingGradientWarning,
                stacklevel=3,
            )
        return has_out
    return bool(use_gradient)


def log_columns(
    log: pd.DataFrame,
    channels: Sequence[str] = CHANNELS,
    *,
    slices: tuple[np.ndarray, tuple[str, ...], list[np.ndarray]] | None = None,
) -> LogColumns:
    """The columns features of ``channels`` are built from (see :class:`LogColumns`).

    Parameters
    ----------
    log : DataFrame
        A validated calibration log.
    channels : sequence of str
        Channels.
    slices : tuple, optional
        :func:`run_slices` of the log's ``run`` column, when the caller has it already.

    Raises
    ------
    LogError
        A missing column (time, run, a channel or its temperature), named.
    """
    _require(log, channels)
    tcol = {c: temperature_column(log, c) for c in channels}
    names = dict.fromkeys([*channels, *tcol.values()])
    if TEMP_OUT in log.columns:
        names[TEMP_OUT] = None
    codes, runs, rows = run_slices(log[RUN]) if slices is None else slices
    return LogColumns(
        time_s=log[TIME].to_numpy(dtype=np.float64),
        codes=codes,
        runs=runs,
        rows=rows,
        values={c: log[c].to_numpy(dtype=np.float64) for c in names},
        temp_column=tcol,
    )


#: Most temperature columns whose rate one pass of the rate kernel finds together
#: (:func:`column_rates`), and most bytes of one such block of a run [bytes]: a block stays
#: below glibc's mmap threshold (32 MiB), so that it comes from the heap and the next run
#: reuses its pages instead of having new ones faulted in and zeroed.
RATE_GROUP = 3
RATE_BLOCK_BYTES = 24 * 2**20


def column_rates(
    cols: LogColumns,
    derivative: DerivativeConfig,
    names: Sequence[str],
    n_jobs: int | None = 1,
) -> list[np.ndarray]:
    """The temperature rate of each of the columns ``names`` of ``cols``, run by run
    [°C/min].

    The columns go through the rate kernel in groups (:data:`RATE_GROUP` columns at most, a
    run's block of a group at most :data:`RATE_BLOCK_BYTES`), one pass per run and group,
    the groups on up to ``n_jobs`` threads (None/0: every core): the rate of a column does
    not depend on the columns computed with it (bit for bit), so this is what each column's
    features hold (:func:`features_from_columns`) whatever the grouping and the threads.

    Returns
    -------
    list of ndarray, shape (n,)
        The rate of each of ``names``, in order (views of a group's row-major block).
    """
    # deferred: the thread fan-out is needed only here
    from rinscal.parallel import map_jobs

    t = cols.time_s
    longest = max((idx.size for idx in cols.rows), default=0)
    size = max(1, min(RATE_GROUP, RATE_BLOCK_BYTES // max(8 * longest, 1)))
    groups = [list(names[k : k + size]) for k in range(0, len(names), size)]

    def group_rates(group: list[str]) -> np.ndarray:
        x = np.column_stack([cols.values[c] for c in group])  # the kernel runs along rows
        if len(cols.rows) == 1 and cols.rows[0].size == t.size:  # one run: no copy
            return temperature_rate(t, x, derivative)
        out = np.empty_like(x)
        for idx in cols.rows:
            r = run_index(idx)
            out[r] = temperature_rate(t[r], x[r], derivative)
        return out

    blocks = map_jobs(group_rates, groups, n_jobs)
    return [block[:, j] for block in blocks for j in range(block.shape[1])]


def channel_matrix(
    cols: LogColumns, channel: str, rate: np.ndarray, use_gradient: bool
) -> np.ndarray:
    """One channel's model inputs from the log's columns and its rate found already
    (:func:`column_rates`): what :meth:`Features.matrix` of :func:`features_from_columns`
    gives, without the fitting masks.

    Parameters
    ----------
    cols : LogColumns
        The log's columns.
    channel : str
        The channel.
    rate : ndarray, shape (n,) [°C/min]
        The rate of the channel's temperature column (a strided view is fine).
    use_gradient : bool
        Append ``ΔT = T − temp_out`` (decided: :func:`gradient_choice`).

    Returns
    -------
    ndarray, shape (n, 2 or 3), column-major
        ``T`` [°C], ``Ṫ`` [°C/min] and, with the gradient, ``ΔT`` [°C].
    """
    if use_gradient and not cols.has_temp_out:
        raise LogError(f"log has no {TEMP_OUT!r} column, needed for the gradient feature ΔT")
    temp = cols.values[cols.temp_column[channel]]
    x = np.empty((temp.size, 3 if use_gradient else 2), order="F")
    x[:, 0] = temp
    x[:, 1] = rate
    if use_gradient:
        np.subtract(x[:, 0], cols.values[TEMP_OUT], out=x[:, 2])
    return x


def _columns(values: Mapping[str, np.ndarray], names: Sequence[str], n: int) -> np.ndarray:
    """Columns as a column-major (n, len(names)) float64 array."""
    out = np.empty((n, len(names)), order="F")
    for j, c in enumerate(names):
        out[:, j] = values[c]
    return out


def build_features(
    log: pd.DataFrame,
    derivative: DerivativeConfig | None = None,
    outliers: OutlierConfig | None = None,
    channels: Sequence[str] = CHANNELS,
    *,
    use_gradient: bool | None = None,
    with_rate: bool = True,
    n_jobs: int | None = 1,
) -> Features:
    """Build the model inputs of every channel, run by run.

    Parameters
    ----------
    log : DataFrame
        A validated calibration log (see :func:`rinscal.schema.validate_log`).
    derivative : DerivativeConfig, optional
        Temperature-rate estimator (default: centred, 60 s).
    outliers : OutlierConfig, optional
        Outlier masking (default: 10 s running median, decimated at high rates, 6 robust
        spreads).
    channels : sequence of str
        Channels to build, default all of :data:`rinscal.schema.CHANNELS`.
    use_gradient : bool, optional
        None (default): use ΔT when the log has ``temp_out``, warn when it has not. True:
        require ``temp_out``. False: leave ΔT out.
    with_rate : bool
        Compute the rate ``Ṫ`` (False: zeros, for models of ``T`` alone; the compiled rate
        kernel is then not even loaded).
    n_jobs : int, optional
        Threads over the runs (None or 0: every core); the features do not depend on it.

    Returns
    -------
    Features

    Raises
    ------
    LogError
        If a required column is missing.

    Warns
    -----
    MissingGradientWarning
        When ``use_gradient`` is None and the log has no ``temp_out``.
    """
    channels = tuple(channels)
    _require(log, channels)
    grad = gradient_choice(log, use_gradient)
    return features_from_columns(
        log_columns(log, channels),
        derivative,
        outliers,
        channels,
        use_gradient=grad,
        with_rate=with_rate,
        n_jobs=n_jobs,
    )


def features_from_columns(
    cols: LogColumns,
    derivative: DerivativeConfig | None = None,
    outliers: OutlierConfig | None = None,
    channels: Sequence[str] = CHANNELS,
    *,
    use_gradient: bool,
    with_rate: bool = True,
    n_jobs: int | None = 1,
) -> Features:
    """:func:`build_features` from a log's columns read already (:func:`log_columns`).

    Reads nothing but ``cols``, so that threads can build the features of several channels
    at once. ``use_gradient`` is decided (:func:`gradient_choice`); the rest as for
    :func:`build_features`.
    """
    # deferred: the thread fan-out is needed only where features are built
    from rinscal.parallel import map_jobs

    derivative = derivative or DerivativeConfig()
    outliers = outliers or OutlierConfig()
    channels = tuple(channels)
    if use_gradient and not cols.has_temp_out:
        raise LogError(f"log has no {TEMP_OUT!r} column, needed for the gradient feature ΔT")
    values = cols.values
    n, m = cols.time_s.size, len(channels)
    t = cols.time_s
    tcols = [cols.temp_column[c] for c in channels]
    uniq = list(dict.fromkeys(tcols))
    col_of = np.array([uniq.index(c) for c in tcols])
    single = m == 1  # one channel (a fit builds them one at a time): no copies between steps
    if single:
        # T, Ṫ (, ΔT) as the columns of one column-major block: the channel's feature
        # matrix as it is (:meth:`Features.matrix` returns it, not a copy)
        block = np.empty((n, 3 if use_gradient else 2), order="F")
        temp, rate = block[:, 0:1], block[:, 1:2]
        temp[:, 0] = values[tcols[0]]
        tmat_u, rate_u = temp, rate  # (n, 1): row-major and column-major alike
    else:
        # the rate kernel runs along rows (row-major); the (n, m) features are column-major,
        # one contiguous column per channel, as every later step reads them
        tmat_u = np.column_stack([values[c] for c in uniq])
        temp = _columns(values, tcols, n)
        rate_u = np.empty_like(tmat_u)
    output = _columns(values, channels, n)
    codes, runs, rows = cols.codes, cols.runs, cols.rows
    outl = np.zeros((n, m), dtype=bool, order="F")
    removed = np.zeros((len(runs), m), dtype=np.int64)
    missing = np.zeros((len(runs), m), dtype=np.int64)

    def one_run(k: int) -> None:
        # each run writes its own rows (and row k of the counts): runs run on any thread
        r = run_index(rows[k])
        tr = t[r]
        rate_u[r] = temperature_rate(tr, tmat_u[r], derivative) if with_rate else 0.0
        if outliers.enabled:
            o = outlier_mask(tr, output[r], outliers, cols.interval(k, tr))
            outl[r] = o
            removed[k] = o.sum(axis=0)
        missing[k] = (~np.isfinite(output[r])).sum(axis=0)

    map_jobs(one_run, range(len(rows)), n_jobs)
    if not single:
        rate = np.empty((n, m), order="F")
        for j, u in enumerate(col_of):
            rate[:, j] = rate_u[:, u]
        del rate_u
    grad = None
    if use_gradient:
        tout = values[TEMP_OUT]
        if single:
            grad = np.subtract(temp, tout[:, None], out=block[:, 2:3])
        else:
            grad = temp - tout[:, None]
    inlier = np.isfinite(output) & ~outl
    report = OutlierReport(
        runs=runs,
        channels=channels,
        removed=removed,
        missing=missing,
        samples=np.array([r.size for r in rows], dtype=np.int64),
    )
    return Features(
        channels=channels,
        temp=temp,
        rate=rate,
        grad=grad,
        output=output,
        inlier=inlier,
        run_codes=codes,
        runs=runs,
        time_s=t,
        derivative=derivative,
        report=report,
    )
