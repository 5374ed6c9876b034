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

Every function here runs through the one :class:`~rinscal.calibration.compensator.Compensator`
(its batch mode; its streaming mode, :meth:`Compensator.update
<rinscal.calibration.compensator.Compensator.update>`, equals :func:`compensate` with
``derivative_kind="causal"``). ``StreamingCompensator`` is its old name, kept for one
release.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from rinscal.calibration.compensator import (
    Compensator,
    imu_calibrated_channels,
    model_features,
)
from rinscal.calibration.imustage import PHYSICAL_TO_SI, PHYSICAL_UNITS, ImuStage
from rinscal.calibration.modelfile import FittedModel, Policy
from rinscal.calibration.thermal.features import DerivativeConfig, Features
from rinscal.errors import ConfigError
from rinscal.schema import CHANNELS, unit_factors

__all__ = [
    "FLAG_COLUMN",
    "Compensator",
    "StreamingCompensator",
    "compensate",
    "imu_calibrated_channels",
    "imu_calibrated_frame",
    "model_features",
    "physical_meta",
    "predict_log",
]

#: The old name of :class:`~rinscal.calibration.compensator.Compensator` (its streaming mode),
#: kept for one release.
StreamingCompensator = Compensator

#: Name of the flag column added by :func:`compensate`.
FLAG_COLUMN = "out_of_range"


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


def predict_log(
    log: pd.DataFrame,
    model: FittedModel,
    policy: Policy = "extrapolate",
    derivative_kind: str | None = None,
    features: Features | None = None,
    first_row: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Modelled output ``f`` of every channel of a log, in log units: the batch mode
    :meth:`Compensator.predict <rinscal.calibration.compensator.Compensator.predict>` of
    ``Compensator(model, policy)`` (see there; ``f`` of shape (n, m) [log units] and the
    out-of-range flags, shape (n, m))."""
    return Compensator(model, policy).predict(log, derivative_kind, features, first_row)


def compensate(
    log: pd.DataFrame,
    model: FittedModel,
    policy: Policy = "clamp",
    derivative_kind: str | None = None,
    n_jobs: int | None = 1,
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
    n_jobs : int, optional
        Threads over the channels (None or 0: every core); the output does not depend on it.

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
    values, flagged = Compensator(model, policy).batch(log, derivative_kind, n_jobs=n_jobs)
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
    return Compensator(model, policy).batch(log, derivative_kind, first_row)


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
