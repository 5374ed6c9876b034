"""Compensation of IMU output with a thermal model (Eq. 10), in batch and sample by sample.

``N' = N − (f(T, Ṫ, ΔT) − r)``: each sensor channel loses its modelled output ``f`` and
keeps the static reference ``r`` (the Earth rate or gravity component the IMU read on the
calibration table, from the model file), so a compensated log still reads Earth rate and
gravity. When the model file has no static reference (the calibration log had no site
metadata) ``r = 0`` and the result is Eq. 10 literally: the compensated output then
scatters about zero.

Every input row and column is kept, in order; each modelled channel is replaced by its
compensated value, and a boolean column ``out_of_range`` flags rows where, for any channel,
an input lies outside its training range or the combination (T, Ṫ, ΔT) lies outside the
joint domain of the training data (the model file's occupancy grid). The policy decides
what happens there: ``clamp`` (inputs clipped to the training range), ``fallback`` (the
channel's T-only fallback model on the flagged rows), ``extrapolate`` (the model as is) or
``error`` (:class:`~rinscal.errors.RangeError`). A dropped sample (NaN) stays NaN.

With an IMU calibration in the model file (``fit --imu-cal``), compensation runs in the
file's one order (:data:`rinscal.calibration.imustage.IMU_ORDER`): raw × ``unit_to_si`` →
SI → the inverse sensor model at each channel's inner temperature (scale factor, nonlinear
terms, misalignment; :func:`imu_calibrated_channels`) → deg/h and µg → ``N − (f − r)``. All
six sensor channels are then replaced, and the output is in deg/h and µg whatever the raw
unit. The calibration needs the six raw channels and each channel's inner temperature
(``temp_<channel>``, or the shared ``temp_in``); a NaN temperature gives NaN outputs for
its whole triad (the misalignment couples the axes).

:class:`StreamingCompensator` does the same one sample at a time with the causal rate; it
equals :func:`compensate` with ``derivative_kind="causal"`` (same compiled rate kernel). Its
:meth:`StreamingCompensator.bias_si` gives the modelled bias of a whole thermometer record in
SI units, causal too: what a navigation computer subtracts (:mod:`rinscal.sim.sensors`).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from rinscal.calibration.imustage import PHYSICAL_TO_SI, PHYSICAL_UNITS, ImuStage
from rinscal.calibration.inference import predict_params
from rinscal.calibration.modelfile import FittedModel, Policy, check_policy
from rinscal.calibration.thermal.features import (
    DerivativeConfig,
    Features,
    OutlierConfig,
    build_features,
    temperature_rate,
)
from rinscal.calibration.thermal.rate import CausalSlope
from rinscal.errors import ConfigError, LogError, RangeError
from rinscal.schema import CHANNELS, temperature_column, unit_factors
from rinscal.units import MIN_TO_S

__all__ = [
    "FLAG_COLUMN",
    "StreamingCompensator",
    "compensate",
    "imu_calibrated_channels",
    "imu_calibrated_frame",
    "model_features",
    "physical_meta",
    "predict_log",
]

#: Name of the flag column added by :func:`compensate`.
FLAG_COLUMN = "out_of_range"


def imu_calibrated_channels(
    log: pd.DataFrame, stage: ImuStage, derivative: DerivativeConfig | None = None
) -> dict[str, np.ndarray]:
    """Steps 1-3 of the order of application: a log's raw channels through the IMU calibration.

    Parameters
    ----------
    log : DataFrame
        Calibration log (several runs allowed) with the six sensor channels in the units the
        calibration's stage expects, and each channel's inner temperature.
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


def imu_calibrated_frame(
    log: pd.DataFrame, stage: ImuStage, derivative: DerivativeConfig | None = None
) -> pd.DataFrame:
    """A copy of ``log`` whose six sensor channels went through :func:`imu_calibrated_channels`
    (deg/h and µg)."""
    out = log.copy()
    for c, v in imu_calibrated_channels(log, stage, derivative).items():
        out[c] = v
    return out


def physical_meta(meta: Mapping[str, Any] | None) -> dict[str, Any]:
    """A log's metadata with the sensor units of IMU-calibrated output (deg/h and µg).

    ``units`` and ``unit_to_si`` become :data:`~rinscal.calibration.imustage.PHYSICAL_UNITS`
    for every channel; ``pulse_scale`` (of the raw pulses) is dropped; the rest is kept.
    """
    out = dict(meta or {})
    out.pop("pulse_scale", None)
    out["units"] = {c: PHYSICAL_UNITS[c.partition("_")[0]] for c in CHANNELS}
    out["unit_to_si"] = {c: float(k) for c, k in zip(CHANNELS, PHYSICAL_TO_SI, strict=True)}
    return out


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
        Validated calibration log.
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


def predict_log(
    log: pd.DataFrame,
    model: FittedModel,
    policy: Policy = "extrapolate",
    derivative_kind: str | None = None,
    features: Features | None = None,
    first_row: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Modelled output of every channel of a log.

    Parameters
    ----------
    log : DataFrame
        Validated calibration log.
    model : FittedModel
        The model.
    policy : {"clamp", "fallback", "extrapolate", "error"}
        Handling of samples outside the training data.
    derivative_kind : {"centred", "causal"}, optional
        Override the model's derivative kind.
    features : Features, optional
        Precomputed :func:`model_features` of ``log``.
    first_row : int
        Data rows of the file before ``log`` (a log read run by run), for messages.

    Returns
    -------
    f : ndarray, shape (n, m) [log units]
        Modelled output per channel (:attr:`FittedModel.channels` order).
    out_of_range : ndarray of bool, shape (n, m)
    """
    n, m = len(log), len(model.channels)
    f = np.empty((n, m), order="F")
    flags = np.zeros((n, m), dtype=bool, order="F")
    for j, fj, flagged in _predicted(log, model, policy, derivative_kind, features, first_row):
        f[:, j], flags[:, j] = fj, flagged
    return f, flags


def _predicted(
    log: pd.DataFrame,
    model: FittedModel,
    policy: Policy,
    derivative_kind: str | None,
    features: Features | None,
    first_row: int,
) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
    """Each channel's index, modelled output and out-of-range flags, one at a time."""
    for j, c in enumerate(model.channels):
        # without given features, a channel's at a time: memory of one channel's features
        feats = features or model_features(log, model, derivative_kind, channels=(c,))
        x = feats.matrix(c)
        try:
            fj, flagged = model.predict_channel(c, x, policy)
        except RangeError as exc:
            i = getattr(exc, "row", None)
            if i is None:
                raise
            run = feats.runs[feats.run_codes[i]]
            what = getattr(exc, "what", str(exc))
            raise RangeError(
                f"{c}: data row {first_row + i + 1} (run {run!r}, time {feats.time_s[i]:.6g} s) "
                f"has {what}"
            ) from None
        yield j, fj, flagged


def compensate(
    log: pd.DataFrame,
    model: FittedModel,
    policy: Policy = "clamp",
    derivative_kind: str | None = None,
) -> pd.DataFrame:
    """Compensate a calibration log (Eq. 10).

    Parameters
    ----------
    log : DataFrame
        Validated calibration log (not modified).
    model : FittedModel
        The model.
    policy : {"clamp", "fallback", "extrapolate", "error"}
        Handling of samples outside the training data (see the module docstring).
    derivative_kind : {"centred", "causal"}, optional
        Override the model's derivative kind.

    Returns
    -------
    DataFrame
        Same rows (order and index) and columns as ``log``, each modelled channel replaced by
        ``N − (f − r)``, plus the boolean column ``out_of_range``. With an IMU calibration in
        the model, all six channels, in deg/h and µg (see the module docstring).

    Raises
    ------
    RangeError
        Under policy ``error``, naming the channel, row, run and input.
    """
    values, flagged = compensated_channels(log, model, policy, derivative_kind)
    out = log.copy()
    for c, v in values.items():
        out[c] = v
    out[FLAG_COLUMN] = flagged
    return out


def compensated_channels(
    log: pd.DataFrame,
    model: FittedModel,
    policy: Policy = "clamp",
    derivative_kind: str | None = None,
    first_row: int = 0,
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The compensated channels of a log, ``N − (f − r)``, without copying the log.

    Parameters
    ----------
    log, model, policy, derivative_kind
        As for :func:`compensate`.
    first_row : int
        Data rows of the file before ``log`` (a log read run by run), for messages.

    Returns
    -------
    values : dict of str to ndarray, shape (n,)
        Each modelled channel, compensated [log units]; with an IMU calibration in the model,
        all six channels, IMU-calibrated and compensated [deg/h, µg].
    flagged : ndarray of bool, shape (n,)
        The ``out_of_range`` column: some channel's inputs outside its training data.
    """
    check_policy(policy)
    missing = [c for c in model.channels if c not in log.columns]
    if missing:
        raise LogError(f"log has no column(s) {missing} that the model compensates")
    values: dict[str, np.ndarray] = {}
    if model.imu_stage is not None:  # steps 1-3: raw → SI → inverse sensor model → deg/h, µg
        deriv = DerivativeConfig(
            window_s=model.derivative_window_s, kind=derivative_kind or model.derivative_kind
        )
        values = imu_calibrated_channels(log, model.imu_stage, deriv)
    any_flag = np.zeros(len(log), dtype=bool)
    for j, fj, flagged in _predicted(log, model, policy, derivative_kind, None, first_row):
        c = model.channels[j]
        ref = model.models[c].static_reference or 0.0
        y = values[c] if c in values else log[c].to_numpy(dtype=np.float64)
        values[c] = y - (fj - ref)  # a channel at a time
        any_flag |= flagged
    return values, any_flag


class StreamingCompensator:
    """Sample-by-sample compensation with the causal temperature rate.

    Equals :func:`compensate` run with ``derivative_kind="causal"`` on the same samples
    (to rounding: the rate comes from the same compiled kernel). With an IMU calibration in
    the model, each sample goes through the same order (raw → SI → inverse sensor model →
    deg/h, µg → thermal bias): ``raw`` and ``temp`` are then the six channels in
    :data:`~rinscal.schema.CHANNELS` order and the output is the six channels in deg/h
    and µg.

    Parameters
    ----------
    model : FittedModel
        The model.
    policy : {"clamp", "fallback", "extrapolate", "error"}
        Handling of samples outside the training data.

    Examples
    --------
    >>> comp = StreamingCompensator(model)                          # doctest: +SKIP
    >>> for t, raw, temps, t_out in samples:                        # doctest: +SKIP
    ...     corrected, flagged = comp.update(t, raw, temps, t_out)
    """

    def __init__(self, model: FittedModel, policy: Policy = "clamp") -> None:
        check_policy(policy)
        self.model = model
        self.policy = policy
        self._m = len(model.channels)
        self._ref = np.array([model.models[c].static_reference or 0.0 for c in model.channels])
        # the channels a sample holds: the model's, or all six behind an IMU calibration
        self._io = CHANNELS if model.imu_stage is not None else tuple(model.channels)
        self._pos = [self._io.index(c) for c in model.channels]
        self.reset()

    def reset(self) -> None:
        """Start a new run (power-on): forget the temperature history."""
        self._slope: CausalSlope | None = None
        self._shared: bool | None = None

    def update(
        self,
        time_s: float,
        raw: Any,
        temp: Any,
        temp_out: float | None = None,
    ) -> tuple[np.ndarray, bool]:
        """Compensate one sample.

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
        stage = self.model.imu_stage
        if stage is not None:  # steps 1-3 of the order of application
            tdot = rate[None, :] if stage.needs_rate else None
            raw = stage.physical(raw[None, :], temps[None, :], tdot)[0]
        out = raw.copy()
        flag = False
        for j, c in enumerate(self.model.channels):
            i = self._pos[j]
            x = self.model.feature_matrix(c, temps[i : i + 1], rate[i : i + 1], temp_out)
            x, fl = self.model.apply_policy(c, x, self.policy)
            f = predict_params(self.model.models[c].params, x)[0]
            out[i] = raw[i] - (f - self._ref[j])
            flag = flag or bool(fl[0])
        return out, flag

    def bias_si(
        self,
        time_s: np.ndarray,
        temp: np.ndarray,
        temp_out: np.ndarray | None = None,
        channels: Sequence[str] = CHANNELS,
    ) -> np.ndarray:
        """The modelled thermal bias of a thermometer record, causal, in SI units.

        ``(f(T, Ṫ, ΔT) − r) · unit_to_si`` per channel (the thermal step alone: behind an
        IMU calibration, subtract it from :meth:`ImuStage.correct_si
        <rinscal.calibration.imustage.ImuStage.correct_si>` of the raw output)
        (:meth:`~rinscal.calibration.modelfile.FittedModel.predict_bias_si`), ``Ṫ`` the
        causal windowed slope of the record: what a navigation computer reading its
        thermometers at ``time_s`` subtracts from each channel.

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
            Bias of each channel; zero on channels the model lacks.

        Raises
        ------
        ConfigError
            A model channel that is not among ``channels``.
        """
        channels = tuple(channels)
        rate = temperature_rate(
            time_s, temp, DerivativeConfig(window_s=self.model.derivative_window_s, kind="causal")
        )
        idx = []
        for c in self.model.channels:
            if c not in channels:
                raise ConfigError(f"model channel {c!r} is not one of {channels}")
            idx.append(channels.index(c))
        bias = np.zeros((np.shape(time_s)[0], len(channels)))
        bias[:, idx] = self.model.predict_bias_si(
            temp[:, idx], rate[:, idx], temp_out, policy=self.policy
        )
        return bias


def check_units(model: FittedModel, meta: Mapping[str, Any] | None, source: str = "log") -> None:
    """Refuse a log whose channel units differ from those the model was fitted in.

    Parameters
    ----------
    model : FittedModel
        The model (its channels' ``unit``; behind an IMU calibration, the calibration's
        input units).
    meta : mapping, optional
        The log's metadata (``units``: per channel or per sensor type, as written by
        ``rinscal simulate`` or a mapping's ``[units]``); a channel without a unit on either
        side is not checked.
    source : str
        Name of the log, for the message.

    Raises
    ------
    ConfigError
        Naming every channel whose units differ, with both units.
    """
    stage = model.imu_stage
    if stage is not None:  # the raw log goes into the IMU calibration, in its input units
        want = dict(stage.input_units)
    else:
        want = {c: model.models[c].unit for c in model.channels}
    units, _ = unit_factors(meta, tuple(want))
    what = "model's IMU calibration" if stage is not None else "model"
    bad = [
        f"{c}: {what} in {want[c]!r}, log in {units[c]!r}"
        for c in want
        if want[c] and units.get(c) and units[c] != want[c]
    ]
    if bad:
        raise ConfigError(
            f"{source}: units differ from the model's ({'; '.join(bad)}); convert the log, "
            "or pass ignore_units=True if the numbers are in fact comparable"
        )


def describe_reference(model: FittedModel) -> tuple[str, list[str]]:
    """What compensation subtracts, in words: ``N − (f − r)`` and where ``r`` comes from.

    Parameters
    ----------
    model : FittedModel
        The model.

    Returns
    -------
    summary : str
        One sentence: the static output ``r`` each channel keeps and its origin (the site's
        gravity and Earth rate, the training mean, or values given at fit time).
    missing : list of str
        Channels without a static reference: compensation removes their whole modelled
        output, static level (gravity, Earth rate) included.
    """
    src = model.source or {}
    given = src.get("static_reference")
    if given == "mean":
        origin = "each channel's training mean (fit --static-ref mean)"
    elif isinstance(given, Mapping) and given:
        origin = (
            "values given at fit time (--static-ref "
            + ", ".join(f"{c}={v:g}" for c, v in given.items())
            + ")"
        )
    elif "latitude_deg" in src and "heading_deg" in src:
        origin = (
            f"gravity and Earth rate at latitude {float(src['latitude_deg']):g}°, heading "
            f"{float(src['heading_deg']):g}°"
        )
    else:
        origin = "none"
    missing = [c for c in model.channels if model.models[c].static_reference is None]
    kept = [c for c in model.channels if c not in missing]
    if kept:

        def value(c: str) -> str:
            r = float(model.models[c].static_reference or 0.0)
            r = 0.0 if abs(r) < 1e-9 else r  # Earth rate on an axis pointing east
            return f"{c} {r:.6g} {model.models[c].unit or ''}".rstrip()

        refs = ", ".join(value(c) for c in kept)
        summary = (
            f"subtracted the modelled thermal bias f − r; r, the static output kept: {refs} "
            f"({origin})"
        )
    else:
        summary = "subtracted the whole modelled output f (no static reference in the model)"
    return summary, missing
