"""An IMU calibration against the log it is applied to: the raw units it was made from, the
unit it was made on, the temperatures it covered.

An IMU calibration turns raw output in its own units into rates and specific forces at each
channel's temperature: applied to a log in other units (one already in deg/h and µg, for a
calibration made from pulses) or outside its temperature range (where each law is held at its
edge value) it answers without a sign of trouble. :func:`imu_stage` refuses the first and
:func:`imu_stage_notes` and :class:`CalibrationRangeTally` say the rest in words, for
``fit --imu-cal``; :func:`check_log_for_imu` serves the compensators of a model file that holds
the calibration.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from rinscal.calibration.imustage import ImuStage
from rinscal.errors import ConfigError
from rinscal.io.imucal import ImuCalibrationFile, load_imu_calibration, unit_identity
from rinscal.schema import CHANNELS, temperature_column, unit_factors
from rinscal.sensormodel import ImuCalibration

__all__ = [
    "RANGE_MARGIN_C",
    "CalibrationRangeTally",
    "ImuCalLike",
    "check_log_for_imu",
    "check_recording_for_imu",
    "imu_stage",
    "imu_stage_notes",
]

ImuCalLike = str | os.PathLike[str] | ImuCalibration
#: A reading counts as outside an IMU calibration's range beyond this margin [°C]
#: (thermometer noise and the drift within a set point, about the set points' means).
RANGE_MARGIN_C = 0.1


def imu_stage(
    calibration: ImuCalLike, meta: Mapping[str, Any] | None, source: str = "the log"
) -> ImuStage:
    """An IMU calibration and the raw units of a log (from its metadata), as a model file's
    first step (what :func:`fit` warns of, here issued as :class:`UserWarning`).

    Raises
    ------
    ConfigError
        A channel whose unit or SI factor the metadata does not give, or whose unit differs
        from the calibration's raw unit (naming it and both units), or a calibration file
        that cannot be read (naming the file).
    """
    stage, notes = imu_stage_notes(calibration, meta, source)
    for note in notes:
        warnings.warn(note, UserWarning, stacklevel=2)
    return stage


def imu_stage_notes(
    calibration: ImuCalLike, meta: Mapping[str, Any] | None, source: str
) -> tuple[ImuStage, list[str]]:
    """:func:`imu_stage` and its warnings, in words (the file's notes, undeclared units,
    another unit): what :func:`rinscal.calibration.workflow.fit` puts in its warnings."""
    if isinstance(calibration, ImuCalibration):
        held = ImuCalibrationFile(calibration)
        what = "the IMU calibration"
    else:
        held = load_imu_calibration(calibration)
        what = f"the IMU calibration {calibration}"
    notes = list(held.notes)
    notes += check_log_for_imu(held.input_units, held.unit, meta, source, what)
    units, factors = unit_factors(meta, CHANNELS)
    missing = [c for c in CHANNELS if factors[c] is None]
    if missing:
        raise ConfigError(
            f"{source}: the IMU calibration turns raw output into SI with each channel's "
            f"unit_to_si, and the log's metadata gives none for {', '.join(missing)} (units "
            "and unit_to_si in its .meta.json, or a mapping's [units])"
        )
    stage = ImuStage(
        held.calibration, units, {c: float(factors[c] or 0.0) for c in CHANNELS}, held.unit
    )
    return stage, notes


def check_log_for_imu(
    raw_units: Mapping[str, str | None] | None,
    unit: Mapping[str, Any] | None,
    meta: Mapping[str, Any] | None,
    source: str = "the log",
    what: str = "the IMU calibration",
    refuse: bool = True,
) -> list[str]:
    """Check a log against the raw units and the unit an IMU calibration was made on.

    An IMU calibration turns raw output in its own units into rates and specific forces:
    applied to numbers in other units (a log already in deg/h and µg, for one made from
    pulses) it gives nonsense without a sign. This refuses that, and says what it cannot
    check.

    Parameters
    ----------
    raw_units : mapping of channel to unit, or None
        The calibration's raw unit of each channel (None: not recorded, nothing compared).
    unit : mapping, optional
        The unit the calibration was made on (:data:`rinscal.io.imucal.UNIT_KEYS`).
    meta : mapping, optional
        The log's metadata (``units``; ``imu``, ``serial``, ``device_ids``).
    source, what : str
        The log's and the calibration's names, for the messages.
    refuse : bool
        Refuse differing units (``False``: the caller was told to ignore units).

    Returns
    -------
    list of str
        Warnings: channels whose unit the log does not declare; a unit identity that differs.

    Raises
    ------
    ConfigError
        Naming each channel whose declared unit differs from the calibration's raw unit,
        with both units.
    """
    log_units, _ = unit_factors(meta, CHANNELS)
    raw = dict(raw_units or {})
    notes: list[str] = []
    pairs: dict[tuple[str, str], list[str]] = {}
    for c in CHANNELS:
        if raw.get(c) and log_units.get(c) and log_units[c] != raw[c]:
            pairs.setdefault((str(log_units[c]), str(raw[c])), []).append(c)
    bad = [
        f"{', '.join(chans)}: log in {lu!r}, {what} made from {ru!r}"
        for (lu, ru), chans in pairs.items()
    ]
    if bad and refuse:
        raise ConfigError(
            f"{source}: its units differ from the raw units of {what} ({'; '.join(bad)}): the "
            "calibration turns raw output in its own units into rates and specific forces, "
            "and would be applied to numbers in other units; give the log in the "
            "calibration's raw units (or a calibration made from this log's units)"
        )
    undeclared = [c for c in CHANNELS if not log_units.get(c)]
    if undeclared:
        known = sorted({str(raw[c]) for c in undeclared if raw.get(c)})
        notes.append(
            f"{source}: the log declares no unit for {', '.join(undeclared)} (its metadata's "
            "units): nothing checks that it is in the raw units of "
            f"{what}{' (' + ', '.join(known) + ')' if known else ''}"
        )
    ident = unit_identity(meta)
    made_on = dict(unit or {})
    diff = [
        f"{k} {made_on[k]!r} (the calibration) vs {ident[k]!r} (the log)"
        for k in made_on
        if k in ident and ident[k] != made_on[k]
    ]
    if diff:
        notes.append(
            f"{source}: {what} was made on another unit than the log's ({'; '.join(diff)}): "
            "a calibration holds for the unit it was made on"
        )
    return notes


class CalibrationRangeTally:
    """Rows of a log, run by run, whose channel temperatures leave an IMU calibration's
    range by more than :data:`RANGE_MARGIN_C` (outside it each law is held at its edge
    value: :class:`ImuCalibration <rinscal.sensormodel.ImuCalibration>`).

    Parameters
    ----------
    t_range_c : (float, float) [°C]
        The calibration's temperature range (its set points' mean inner temperatures, so
        the calibration's own log scatters a little beyond it: hence the margin).
    """

    def __init__(self, t_range_c: tuple[float, float]) -> None:
        self.lo, self.hi = (float(v) for v in t_range_c)
        self.rows = 0
        self.outside = 0
        #: per temperature column: channels, min, max, rows outside, rows read
        self.columns: dict[str, list[Any]] = {}

    def add(self, log: pd.DataFrame) -> None:
        """Count one run (or any piece of a log) with its channels' temperature columns."""
        cols = {}
        for c in CHANNELS:
            cols.setdefault(temperature_column(log, c), []).append(c)
        temps = log[list(cols)].to_numpy(dtype=np.float64)
        out = (temps < self.lo - RANGE_MARGIN_C) | (temps > self.hi + RANGE_MARGIN_C)
        read = np.isfinite(temps)
        self.rows += int(read.any(axis=1).sum())
        self.outside += int(out.any(axis=1).sum())
        for j, (col, chans) in enumerate(cols.items()):
            v = temps[read[:, j], j]
            entry = self.columns.setdefault(col, [chans, np.inf, -np.inf, 0, 0])
            if v.size:
                entry[1], entry[2] = min(entry[1], float(v.min())), max(entry[2], float(v.max()))
            entry[3] += int(out[:, j].sum())
            entry[4] += int(v.size)

    def notes(self, source: str, what: str = "the IMU calibration") -> list[str]:
        """A warning naming the temperature columns (and their channels) that leave the
        range, the log's range, the calibration's range and the share of rows outside; none
        when every reading lies inside."""
        if not self.outside:
            return []
        parts = [
            f"{col} ({', '.join(chans)}) {lo:.2f} .. {hi:.2f} °C, "
            f"{100 * k / max(n, 1):.1f} % of its readings outside"
            for col, (chans, lo, hi, k, n) in self.columns.items()
            if k
        ]
        return [
            f"{source}: {100 * self.outside / max(self.rows, 1):.1f} % of the rows "
            f"({self.outside:,} of {self.rows:,}) lie more than {RANGE_MARGIN_C:g} °C outside "
            f"the temperature range of {what}, "
            f"{self.lo:.2f} .. {self.hi:.2f} °C: {'; '.join(parts)}. There its laws are held at "
            "their edge values (scale factors and misalignments not calibrated at those "
            "temperatures); calibrate over the log's range"
        ]


def check_recording_for_imu(
    stage: ImuStage,
    kind: str,
    units: Mapping[str, str],
    declared: bool,
    meta: Mapping[str, Any] | None,
    source: str,
    what: str = "the model's IMU calibration",
) -> list[str]:
    """:func:`check_log_for_imu` for a recorded-navigation log (``navigate --log``).

    Parameters
    ----------
    stage : ImuStage
        The model file's IMU calibration.
    kind : {"rates", "counts", "increments"}
        How the recording holds the IMU's output (:func:`rinscal.io.navopen.open_nav_log`).
    units : mapping of channel to unit
        The recording's units (rates), as read.
    declared : bool
        Whether a mapping or the metadata declared the rate units (not the defaults).
    meta : mapping, optional
        The recording's metadata (the unit's identity).
    source : str

    Returns
    -------
    list of str
        Warnings, as :func:`check_log_for_imu`.

    Raises
    ------
    ConfigError
        Rates declared in other units than the calibration's raw units; counts for a
        calibration made from rates (or rates for one made from pulses).
    """
    if kind == "counts":
        log_units: dict[str, str] = {c: "pulse" for c in CHANNELS}
    elif kind == "rates" and declared:
        log_units = {c: units[c] for c in CHANNELS if c in units}
    else:  # increments in rad and m/s, or rates in the default units: nothing declared
        log_units = {}
    ident = unit_identity(meta)
    return check_log_for_imu(
        stage.input_units, stage.unit, {**ident, "units": log_units}, source, what
    )
