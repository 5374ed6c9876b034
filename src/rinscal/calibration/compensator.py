"""The one thermal compensator: a fitted model's bias ``f(T, Ṫ, ΔT) − r`` in three modes.

:class:`Compensator` holds a fitted model and an out-of-range policy and computes the bias
in one place (:meth:`Compensator.output`: features → model under the policy → ``f`` and its
flags; :meth:`Compensator.bias`: ``f − r``, ``r`` the static reference the channel keeps;
:meth:`Compensator.bias_si`: the same in SI). Every way of compensating runs through it:

- **batch** (:meth:`Compensator.batch`, :meth:`Compensator.predict`): a whole log, the rate
  from the model's derivative (centred or causal), ``N − (f − r)`` per channel — what
  :func:`rinscal.calibration.compensate.compensate` and :mod:`rinscal.calibration.evaluate`
  do;
- **streaming** (:meth:`Compensator.update`): one sample at a time with the causal rate;
  equals batch with ``derivative_kind="causal"`` on the same samples;
- **causal, held between thermometer readings** (:meth:`Compensator.__call__` on a
  recording's :class:`~rinscal.schema.NavSamples` pieces, :meth:`Compensator.record_bias_si`
  with :func:`hold` on a thermometer record): the thermometers are read once per
  ``update_s``, the rate is the causal windowed slope of the readings, and the bias in SI is
  held until the next reading — what a navigation computer subtracts (recorded navigation,
  :mod:`rinscal.nav.recorded`; simulated navigation, :class:`rinscal.nav.sensors.ModelCompensator`).

Behind an IMU calibration in the model file (:attr:`FittedModel.imu_stage`) each mode applies
the file's one order: raw → SI → inverse sensor model at the channel temperatures → thermal
bias.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from rinscal.calibration.imustage import ImuStage
from rinscal.calibration.modelfile import FittedModel, Policy, check_policy
from rinscal.calibration.thermal.features import (
    DerivativeConfig,
    Features,
    OutlierConfig,
    build_features,
    channel_matrix,
    column_rates,
    gradient_choice,
    log_columns,
    temperature_rate,
)
from rinscal.errors import ConfigError, LogError, RangeError
from rinscal.schema import CHANNELS, NavSamples, temperature_column
from rinscal.units import MIN_TO_S

__all__ = [
    "Compensator",
    "forward_fill",
    "hold",
    "imu_calibrated_channels",
    "model_features",
]


def imu_calibrated_channels(
    log: pd.DataFrame, stage: ImuStage, derivative: DerivativeConfig | None = None
) -> dict[str, np.ndarray]:
    """Steps 1-3 of the order of application: a log's raw channels through the IMU calibration.

    Parameters
    ----------
    log : DataFrame
        Calibration log (several runs allowed) with the six sensor channels in the units the
        calibration's stage expects, and each channel's inner temperature [°C].
    stage : ImuStage
        The IMU calibration and the raw units (:attr:`FittedModel.imu_stage`).
    derivative : DerivativeConfig, optional
        The temperature-rate estimator, used only by a calibration with laws in the rate
        (a ramp calibration); default 60 s centred.

    Returns
    -------
    dict of str to ndarray, shape (n,)
        Each of the six channels, IMU-calibrated, in deg/h (gyros) and µg (accelerometers);
        the calibration's biases are left in (the thermal model removes them).

    Raises
    ------
    LogError
        A sensor channel or a channel's temperature missing from the log, naming the column.
    """
    missing = [c for c in CHANNELS if c not in log.columns]
    if missing:
        raise LogError(
            f"the IMU calibration needs all six sensor channels; the log has no column(s) "
            f"{', '.join(missing)}"
        )
    temp_cols = []
    for c in CHANNELS:
        try:
            temp_cols.append(temperature_column(log, c))
        except LogError as exc:
            raise LogError(
                f"the IMU calibration is applied at each channel's inner temperature: {exc}"
            ) from None
    raw = log[list(CHANNELS)].to_numpy(dtype=np.float64)
    temp = log[temp_cols].to_numpy(dtype=np.float64)
    tdot = None
    if stage.needs_rate:
        deriv = derivative or DerivativeConfig()
        tdot = np.empty_like(temp)
        time = log["time_s"].to_numpy(dtype=np.float64)
        for rows in log.groupby("run", sort=False).indices.values():  # the rate is per run
            tdot[rows] = temperature_rate(time[rows], temp[rows], deriv)
    y = stage.physical(raw, temp, tdot)
    return {c: y[:, j] for j, c in enumerate(CHANNELS)}


def model_features(
    log: pd.DataFrame,
    model: FittedModel,
    derivative_kind: str | None = None,
    outliers: OutlierConfig | None = None,
    channels: Sequence[str] | None = None,
) -> Features:
    """Features of a log as the model defines them (window, kind, gradient).

    Parameters
    ----------
    log : DataFrame
        Validated calibration log (time [s], temperatures [°C]).
    model : FittedModel
        The model.
    derivative_kind : {"centred", "causal"}, optional
        Override the model's derivative kind (e.g. ``"causal"`` for real-time behaviour).
    outliers : OutlierConfig, optional
        Outlier masking (default: none; compensation keeps every sample).
    channels : sequence of str, optional
        Those of the model's channels to build (default all).

    Returns
    -------
    Features
        ``T`` [°C], ``Ṫ`` [°C/min] and, if the model uses it, ``ΔT`` [°C] per channel.
    """
    deriv = DerivativeConfig(
        window_s=model.derivative_window_s, kind=derivative_kind or model.derivative_kind
    )
    return build_features(
        log,
        deriv,
        outliers or OutlierConfig(enabled=False),
        model.channels if channels is None else tuple(channels),
        use_gradient=model.use_gradient,
    )


def hold(
    reading_times: NDArray[np.float64], values: NDArray[np.float64], t: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Values held from the last reading at or before each time (the first one before it).

    Parameters
    ----------
    reading_times : ndarray, shape (k,) [s]
        Reading times, increasing.
    values : ndarray, shape (k, ...)
        The value of each reading (any unit).
    t : ndarray, shape (n,) [s]
        Times to read the held value at.

    Returns
    -------
    ndarray, shape (n, ...)
        ``values`` of the last reading at or before each ``t``.
    """
    k = np.searchsorted(reading_times, np.asarray(t, dtype=float), side="right") - 1
    return values[np.clip(k, 0, reading_times.size - 1)]


def forward_fill(x: NDArray[np.float64], last: float) -> NDArray[np.float64]:
    """``x`` (n,) with each NaN replaced by the last finite value before it (``last``
    before the first finite one); any unit."""
    ok = np.isfinite(x)
    if ok.all():
        return x
    idx = np.where(ok, np.arange(x.size), -1)
    np.maximum.accumulate(idx, out=idx)
    return np.where(idx >= 0, x[np.maximum(idx, 0)], last)


class Compensator:
    """A thermal model file's compensation: batch, streaming and causal modes, one bias.

    Parameters
    ----------
    model : FittedModel
        The fitted model (its channels, static references ``r`` and units).
    policy : {"clamp", "fallback", "extrapolate", "error"}
        Handling of inputs outside the training data (every mode).
    update_s : float [s]
        Causal mode only: the thermometer reading interval (the simulator's is 1 s).

    Examples
    --------
    A whole log, one sample, a recording's piece:

    >>> comp = Compensator(model)                                   # doctest: +SKIP
    >>> values, flagged = comp.batch(log)                           # doctest: +SKIP
    >>> corrected, flag = comp.update(t, raw, temps, t_out)         # doctest: +SKIP
    >>> bias_si = comp(piece)                                       # doctest: +SKIP
    """

    def __init__(self, model: FittedModel, policy: Policy = "clamp", update_s: float = 1.0) -> None:
        check_policy(policy)
        if not (math.isfinite(update_s) and update_s > 0):
            raise ConfigError(f"model update interval must be > 0 s, got {update_s}")
        self.model = model
        self.policy: Policy = policy
        self.update_s = float(update_s)
        self.channels = tuple(model.channels)
        self._ref = np.array([model.models[c].static_reference or 0.0 for c in self.channels])
        #: the model uses the gradient ΔT (needs the outer temperature)
        self.needs_outer = bool(model.use_gradient) and any(
            model.models[c].n_inputs >= 3 for c in self.channels
        )
        #: the model file's IMU calibration, applied first (None: the thermal model alone)
        self.stage: ImuStage | None = model.imu_stage
        # the channels a streamed sample holds: the model's, or all six behind an IMU stage
        self._io = CHANNELS if self.stage is not None else self.channels
        self._pos = [self._io.index(c) for c in self.channels]
        self.reset()

    # ------------------------------------------------------------ the one bias computation
    def output(
        self, j: int, x: NDArray[np.float64], where: Features | None = None, first_row: int = 0
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """The model's output ``f`` of channel ``j`` under the policy, and its flags.

        Parameters
        ----------
        j : int
            Index of the channel in :attr:`channels`.
        x : ndarray, shape (n, k)
            ``T`` [°C], ``Ṫ`` [°C/min] and, if used, ``ΔT`` [°C].
        where : Features, optional
            The log's features ``x`` came from: a :class:`~rinscal.errors.RangeError` then
            names the data row, run and time.
        first_row : int
            Data rows of the file before the log (a log read run by run), for messages.

        Returns
        -------
        f : ndarray, shape (n,) [log units]
        flagged : ndarray of bool, shape (n,)
        """
        rows = None if where is None else (where.runs, where.run_codes, where.time_s)
        return self._output(j, x, rows, first_row)

    def _output(
        self,
        j: int,
        x: NDArray[np.float64],
        rows: tuple[Sequence[str], NDArray[np.int64], NDArray[np.float64]] | None,
        first_row: int,
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """:meth:`output`, the rows of ``x`` given by their run names, run of each row and
        time [s] (a :class:`~rinscal.errors.RangeError` names them)."""
        c = self.channels[j]
        try:
            return self.model.predict_channel(c, x, self.policy)
        except RangeError as exc:
            i = getattr(exc, "row", None)
            if i is None or rows is None:
                raise
            runs, codes, time_s = rows
            what = getattr(exc, "what", str(exc))
            raise RangeError(
                f"{c}: data row {first_row + i + 1} (run {runs[codes[i]]!r}, time "
                f"{time_s[i]:.6g} s) has {what}"
            ) from None

    def bias(
        self, temp: NDArray[np.float64], rate: NDArray[np.float64], temp_out: Any = None
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """The bias ``f(T, Ṫ, ΔT) − r`` of every channel from thermometer readings.

        Parameters
        ----------
        temp : ndarray, shape (n, m) [°C]
            Inner temperature of each of :attr:`channels`.
        rate : ndarray, shape (n, m) [°C/min]
            Its rate.
        temp_out : ndarray, shape (n,), optional [°C]
            Outer temperature (needed if the model uses ΔT).

        Returns
        -------
        bias : ndarray, shape (n, m) [log units]
        flagged : ndarray of bool, shape (n, m)
        """
        n = np.shape(temp)[0]
        out = np.empty((n, len(self.channels)))
        flags = np.empty((n, len(self.channels)), dtype=bool)
        for j, c in enumerate(self.channels):
            x = self.model.feature_matrix(c, temp[:, j], rate[:, j], temp_out)
            f, flags[:, j] = self.output(j, x)
            out[:, j] = f - self._ref[j]
        return out, flags

    def bias_si(
        self, temp: NDArray[np.float64], rate: NDArray[np.float64], temp_out: Any = None
    ) -> NDArray[np.float64]:
        """:meth:`bias` in SI: ``(f − r) · unit_to_si``, shape (n, m) [rad/s, m/s²].

        Raises
        ------
        ModelFileError
            When the file lacks the unit or the static reference of a channel.
        """
        k = self.model.si_factors()
        return self.bias(temp, rate, temp_out)[0] * k

    # ------------------------------------------------------------ batch
    def _outputs(
        self,
        log: pd.DataFrame,
        derivative_kind: str | None,
        features: Features | None,
        first_row: int,
        n_jobs: int | None,
        then: Any = None,
        slices: Any = None,
    ) -> list[Any]:
        """Each channel's modelled output [log units] and flags, ``(f, flagged)`` in channel
        order, or what ``then(j, f, flagged)`` makes of them.

        Without given features, the log's columns are read once, the temperature rate of
        every channel found in a pass per run and group of columns (:func:`column_rates`, the
        groups on ``n_jobs`` threads), and each channel's inputs built and evaluated on a
        thread of its own (``n_jobs``): memory of the rates and of ``n_jobs`` channels'
        inputs. ``slices``: :func:`run_slices` of the log's run
        column, when the caller has it. The first error in channel order is raised, as one
        channel after another would.
        """
        if features is None:
            deriv = DerivativeConfig(
                window_s=self.model.derivative_window_s,
                kind=derivative_kind or self.model.derivative_kind,  # type: ignore[arg-type]
            )
            grad = gradient_choice(log, self.model.use_gradient)
            cols = log_columns(log, self.channels, slices=slices)
            tcols = [cols.temp_column[c] for c in self.channels]
            uniq = list(dict.fromkeys(tcols))
            rates = column_rates(cols, deriv, uniq, n_jobs)
            rows = (cols.runs, cols.codes, cols.time_s)

        def one(j: int) -> Any:
            c = self.channels[j]
            if features is not None:
                f, flagged = self.output(j, features.matrix(c), features, first_row)
            else:
                x = channel_matrix(cols, c, rates[uniq.index(tcols[j])], grad)
                f, flagged = self._output(j, x, rows, first_row)
            return (f, flagged) if then is None else then(j, f, flagged)

        # deferred: the thread fan-out is needed only for a batch
        from rinscal.parallel import jobs_within, map_jobs

        # about 100 bytes a row for each channel in flight (inputs, output)
        return map_jobs(one, range(len(self.channels)), jobs_within(n_jobs, 100 * len(log)))

    def predict(
        self,
        log: pd.DataFrame,
        derivative_kind: str | None = None,
        features: Features | None = None,
        first_row: int = 0,
        n_jobs: int | None = 1,
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """Modelled output ``f`` of every channel of a log (batch).

        Parameters
        ----------
        log : DataFrame
            Validated calibration log.
        derivative_kind : {"centred", "causal"}, optional
            Override the model's derivative kind.
        features : Features, optional
            Precomputed :func:`model_features` of ``log``.
        first_row : int
            Data rows of the file before ``log`` (a log read run by run), for messages.
        n_jobs : int, optional
            Threads over the channels (None or 0: every core); the output does not depend
            on it.

        Returns
        -------
        f : ndarray, shape (n, m) [log units]
        out_of_range : ndarray of bool, shape (n, m)
        """
        n, m = len(log), len(self.channels)
        f = np.empty((n, m), order="F")
        flags = np.zeros((n, m), dtype=bool, order="F")

        def put(j: int, fj: NDArray[np.float64], flagged: NDArray[np.bool_]) -> None:
            f[:, j], flags[:, j] = fj, flagged  # each channel its own column

        self._outputs(log, derivative_kind, features, first_row, n_jobs, put)
        return f, flags

    def batch(
        self,
        log: pd.DataFrame,
        derivative_kind: str | None = None,
        first_row: int = 0,
        n_jobs: int | None = 1,
        slices: tuple[NDArray[np.int64], tuple[str, ...], list[NDArray[np.int64]]] | None = None,
    ) -> tuple[dict[str, NDArray[np.float64]], NDArray[np.bool_]]:
        """The compensated channels of a whole log, ``N − (f − r)``, without copying it.

        Parameters
        ----------
        log : DataFrame
            Validated calibration log (not modified).
        derivative_kind : {"centred", "causal"}, optional
            Override the model's derivative kind.
        first_row : int
            Data rows of the file before ``log``, for messages.
        n_jobs : int, optional
            Threads over the channels (None or 0: every core); the output does not depend
            on it.
        slices : tuple, optional
            :func:`~rinscal.calibration.thermal.features.run_slices` of the log's ``run``
            column, when the caller has it already.

        Returns
        -------
        values : dict of str to ndarray, shape (n,)
            Each modelled channel, compensated [log units]; behind an IMU calibration, all
            six channels, IMU-calibrated and compensated [deg/h, µg].
        flagged : ndarray of bool, shape (n,)
            Some channel's inputs outside its training data.
        """
        missing = [c for c in self.channels if c not in log.columns]
        if missing:
            raise LogError(f"log has no column(s) {missing} that the model compensates")
        values: dict[str, NDArray[np.float64]] = {}
        if self.stage is not None:  # steps 1-3: raw → SI → inverse sensor model → deg/h, µg
            deriv = DerivativeConfig(
                window_s=self.model.derivative_window_s,
                kind=derivative_kind or self.model.derivative_kind,
            )
            values = imu_calibrated_channels(log, self.stage, deriv)
        columns = {c: values[c] if c in values else log[c].to_numpy(dtype=np.float64)
                   for c in self.channels}  # fmt: skip

        def compensated(
            j: int, fj: NDArray[np.float64], flagged: NDArray[np.bool_]
        ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
            d = np.subtract(fj, self._ref[j])  # N − (f − r), in one new array
            return np.subtract(columns[self.channels[j]], d, out=d), flagged

        any_flag = np.zeros(len(log), dtype=bool)
        done = self._outputs(
            log, derivative_kind, None, first_row, n_jobs, compensated, slices=slices
        )
        for c, (y, flagged) in zip(self.channels, done, strict=True):
            values[c] = y
            any_flag |= flagged
        return values, any_flag

    # ------------------------------------------------------------ streaming
    def reset(self) -> None:
        """Start a new run (power-on): forget the temperature history of every mode."""
        self._slope: Any = None  # streaming: CausalSlope of the samples
        self._shared: bool | None = None
        self._causal: Any = None  # causal: CausalSlope of the readings
        self._tick = -(2**62)
        self._bias = np.zeros(6)
        self._last_temp: NDArray[np.float64] | None = None
        self._last_out = float("nan")
        self._held_t = np.full(6, np.nan)  # last complete reading of all six thermometers
        self._held_r = np.zeros(6)  # and its rate [°C/min]
        #: causal mode: thermometer readings used
        self.readings = 0
        #: causal mode: readings skipped because no thermometer had read yet
        self.skipped = 0

    def update(
        self, time_s: float, raw: Any, temp: Any, temp_out: float | None = None
    ) -> tuple[NDArray[np.float64], bool]:
        """Compensate one sample (streaming), the rate the causal windowed slope.

        Parameters
        ----------
        time_s : float [s]
            Time since power-on, increasing.
        raw : array_like, shape (m,) [log units]
            Raw output of the model's channels (of all six behind an IMU calibration).
        temp : float or array_like, shape (m,) [°C]
            Inner temperature, shared or per channel (keep the same form within a run).
        temp_out : float, optional [°C]
            Outer temperature (needed if the model uses ΔT).

        Returns
        -------
        compensated : ndarray, shape (m,) [log units, or deg/h and µg behind an IMU calibration]
        out_of_range : bool
        """
        # deferred: rate imports numba (~0.25 s); only a model run causally needs it
        from rinscal.calibration.thermal.rate import CausalSlope

        m = len(self._io)
        temps = np.atleast_1d(np.asarray(temp, dtype=np.float64))
        shared = temps.size == 1
        if self._slope is None:
            self._shared = shared
            self._slope = CausalSlope(self.model.derivative_window_s, temps.size)
        elif shared != self._shared:
            raise ValueError("give the temperature in the same form (shared or per channel)")
        if not shared and temps.size != m:
            raise ValueError(f"temp must be a scalar or have {m} entries")
        slope = self._slope.update(np.array([float(time_s)]), temps[None, :])[0]
        rate = slope * MIN_TO_S
        if shared:
            temps = np.repeat(temps, m)
            rate = np.repeat(rate, m)
        raw = np.asarray(raw, dtype=np.float64).reshape(m)
        if self.stage is not None:  # steps 1-3 of the order of application
            tdot = rate[None, :] if self.stage.needs_rate else None
            raw = self.stage.physical(raw[None, :], temps[None, :], tdot)[0]
        pos = self._pos
        b, flags = self.bias(temps[None, pos], rate[None, pos], temp_out)
        out = raw.copy()
        out[pos] = raw[pos] - b[0]
        return out, bool(flags.any())

    # ------------------------------------------------------------ causal, held
    def record_bias_si(
        self,
        time_s: NDArray[np.float64],
        temp: NDArray[np.float64],
        temp_out: NDArray[np.float64] | None = None,
        channels: Sequence[str] = CHANNELS,
    ) -> NDArray[np.float64]:
        """The bias of a whole thermometer record in SI, the rate causal (hold it with
        :func:`hold` between the readings).

        Parameters
        ----------
        time_s : ndarray, shape (n,) [s]
            Reading times since power-on, increasing.
        temp : ndarray, shape (n, k) [°C]
            Inner temperature of each of ``channels``.
        temp_out : ndarray, shape (n,), optional [°C]
            Outer temperature (needed if the model uses ΔT).
        channels : sequence of str
            The channel of each column of ``temp`` (and of the result).

        Returns
        -------
        ndarray, shape (n, k) [rad/s or m/s²]
            ``(f − r) · unit_to_si`` of each channel; zero on channels the model lacks.

        Raises
        ------
        ConfigError
            A model channel that is not among ``channels``.
        """
        channels = tuple(channels)
        rate = temperature_rate(
            time_s, temp, DerivativeConfig(window_s=self.model.derivative_window_s, kind="causal")
        )
        idx = self._columns(channels)
        bias = np.zeros((np.shape(time_s)[0], len(channels)))
        bias[:, idx] = self.bias_si(temp[:, idx], rate[:, idx], temp_out)
        return bias

    def _columns(self, channels: tuple[str, ...]) -> list[int]:
        idx = []
        for c in self.channels:
            if c not in channels:
                raise ConfigError(f"model channel {c!r} is not one of {channels}")
            idx.append(channels.index(c))
        return idx

    def __call__(self, s: NavSamples) -> NDArray[np.float64]:
        """What to subtract from a recording's piece (causal): (n, 6) SI [rad/s, m/s²].

        The thermometers are read once per ``update_s`` (the first sample whose interval's
        middle falls in a new tick: its temperature columns, dated at the tick); the rate is
        the causal windowed slope over these readings; the bias ``(f − r)`` in SI is held
        until the next reading. A reading with a NaN temperature keeps the last one; readings
        before every thermometer has read are skipped (:attr:`skipped`). Behind an IMU
        calibration, each sample's rates first go through the inverse sensor model at the
        last reading: the result is ``y − inverse(y) + bias``. Pieces come in time order.
        """
        # deferred: rate imports numba (~0.25 s); only a model run causally needs it
        from rinscal.calibration.thermal.rate import CausalSlope

        if s.temps is None:
            raise ConfigError(
                f"a thermal model needs temperatures, and the recording has none for "
                f"{', '.join(self.channels)} (columns temp_<channel> or temp_in)"
            )
        if self._causal is None:
            idx = self._columns(CHANNELS)
            if self.stage is not None and self.stage.needs_rate and len(idx) != 6:
                raise ConfigError(
                    "a model whose IMU calibration has laws in the temperature rate needs all "
                    "six channels' thermal models to follow their temperatures; it has "
                    f"{self.channels}"
                )
            self._causal = CausalSlope(self.model.derivative_window_s, len(idx))
        idx = np.array(self._columns(CHANNELS), dtype=np.int64)
        tick = np.floor((s.t - 0.5 * s.dt) / self.update_s + 1e-9).astype(np.int64)
        new = np.flatnonzero(np.diff(tick, prepend=self._tick) != 0)
        out = np.empty((s.n, 6))
        seg = np.zeros(s.n, dtype=np.int64)
        held_t = held_r = None
        if new.size:
            temp = s.temps[new][:, idx].copy()
            all6 = s.temps[new].copy()
            t_out = None if s.temp_out is None else s.temp_out[new].copy()
            self._fill(temp, t_out)
            # no reading yet (a thermometer empty from the start): the model waits for one
            ok = np.isfinite(temp).all(axis=1)
            if self.needs_outer:
                if t_out is None:
                    raise ConfigError(
                        f"the model uses the gradient ΔT = T − temp_out for "
                        f"{', '.join(self.channels)}, and the recording has no outer "
                        "temperature (a temp_out column, or a mapping onto it)"
                    )
                ok &= np.isfinite(t_out)
            if not ok.all():
                self.skipped += int((~ok).sum())
                new, temp, all6 = new[ok], temp[ok], all6[ok]
                t_out = None if t_out is None else t_out[ok]
        if new.size:
            times = tick[new] * self.update_s
            rate = self._causal.update(times.astype(float), temp) * MIN_TO_S
            bias = np.zeros((new.size, 6))
            bias[:, idx] = self.bias_si(temp, rate, t_out)
            # each sample takes the last reading at or before it (row 0: the one held before)
            seg[new] = 1
            np.cumsum(seg, out=seg)
            np.take(np.vstack([self._bias, bias]), seg, axis=0, out=out)
            self._bias = bias[-1]
            self.readings += new.size
            if self.stage is not None:
                all6[:, idx] = temp  # the held (forward-filled) readings
                rate6 = np.zeros_like(all6)
                rate6[:, idx] = rate
                held_t = np.vstack([self._held_t, all6])
                held_r = np.vstack([self._held_r, rate6])
                self._held_t, self._held_r = all6[-1].copy(), rate6[-1].copy()
        else:
            out[:] = self._bias
        if self.stage is not None:
            if held_t is None or held_r is None:
                held_t, held_r = self._held_t[None, :], self._held_r[None, :]
            out += self._imu_step(s, held_t[seg], held_r[seg])
        self._tick = int(tick[-1])
        return out

    def _imu_step(
        self, s: NavSamples, temp: NDArray[np.float64], rate: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """``y − inverse(y)`` per sample [SI]: what the IMU calibration takes away."""
        assert self.stage is not None
        y = np.column_stack([s.dtheta, s.dv]) / s.dt[:, None]
        ok = np.isfinite(temp).all(axis=1)  # before the first reading: nothing
        step = np.zeros_like(y)
        if ok.any():
            tdot = rate[ok] if self.stage.needs_rate else None
            step[ok] = y[ok] - self.stage.inverse_si(y[ok], temp[ok], tdot)
        return step

    def _fill(self, temp: NDArray[np.float64], t_out: NDArray[np.float64] | None) -> None:
        """Replace NaN readings by the last finite one (forward fill across pieces)."""
        for j in range(temp.shape[1]):
            last = np.nan if self._last_temp is None else self._last_temp[j]
            temp[:, j] = forward_fill(temp[:, j], last)
        self._last_temp = temp[-1].copy()
        if t_out is not None:
            t_out[:] = forward_fill(t_out, self._last_out)
            self._last_out = float(t_out[-1])
