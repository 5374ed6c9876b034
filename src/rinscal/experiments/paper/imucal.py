"""The reproduction's first step (Section 5: "the IMU calibration was done based on our
previous work [29]"): a multi-position and rate-table calibration of the plant on the
two-axis turntable at several chamber set points, the scale factors and misalignments it
finds over temperature, how well they match the plant's truth, and the thermal model of
method 2 fitted behind it.

In the navigation runs the navigation computer holds the unit's calibration at ``t_cal``
(the plant's physical output, :mod:`rinscal.sim.protocols`), so what the IMU
calibration adds is its *thermal part*: each law minus its value at ``t_cal``
(:meth:`rinscal.sensormodel.ImuCalibration.relative_to`). The variant ``regression+sf``
navigates with that thermal part applied to the raw signal first and a method-2 model fitted
on soak output corrected the same way (one model file holding both, as ``rinscal fit
--imu-cal`` writes); ``regression`` leaves the scale-factor and misalignment drift in.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from rinscal.calibration.imu.workflow import ImuCalibrationResult, calibrate_imu
from rinscal.calibration.modelfile import FittedModel
from rinscal.calibration.workflow import fit
from rinscal.experiments.paper.config import ReproConfig
from rinscal.experiments.verdict import HOLDS, REVERSED, UNRESOLVED, interval_text, paired
from rinscal.sensormodel import ImuCalibration
from rinscal.sim.config import ImuConfig
from rinscal.sim.multiposition import simulate_multiposition
from rinscal.sim.sensors import SIGNAL_KINDS

__all__ = [
    "IMU_VARIANT",
    "ImuCalStage",
    "imu_calibration_stage",
    "imu_thermal_model",
    "imu_variant_model",
    "paired_saving_table",
    "recovery_table",
]

#: The navigation variant with the IMU calibration's thermal part (method 2 behind it).
IMU_VARIANT = "regression+sf"


@dataclass(frozen=True)
class ImuCalStage:
    """What the IMU-calibration stage found.

    Attributes
    ----------
    result : ImuCalibrationResult
        The fit (estimates per set point, laws, segments, warnings).
    truth : DataFrame
        The plant's parameters per set point (parameter-table format).
    recovery : DataFrame
        :func:`recovery_table` of the estimate against the truth.
    thermal_part : ImuCalibration
        The calibration's scale-factor, nonlinear and misalignment laws relative to the
        plant's ``t_cal`` (what a computer that holds the calibration at ``t_cal`` adds).
    rows : int
        Rows of the simulated calibration log.
    """

    result: ImuCalibrationResult
    truth: pd.DataFrame
    recovery: pd.DataFrame
    thermal_part: ImuCalibration
    rows: int


def recovery_table(truth: pd.DataFrame, estimate: pd.DataFrame) -> pd.DataFrame:
    """Estimate against truth, one row per parameter: the largest error over the set points
    and the largest error in units of the estimate's sd.

    Parameters
    ----------
    truth, estimate : DataFrame
        Parameter tables (:mod:`rinscal.io.params`), joined on ``temperature_c`` and
        ``parameter``.

    Returns
    -------
    DataFrame
        ``parameter, unit, set points, max |error|, max |error|/sd, truth slope /°C,
        estimated slope /°C`` (slopes by least squares over the set points).
    """
    j = truth.merge(estimate, on=["temperature_c", "parameter"], suffixes=("_true", "_est"))
    rows = []
    for name, g in j.groupby("parameter", sort=False):
        err = (g["value_est"] - g["value_true"]).to_numpy()
        sd = g["sd_est"].to_numpy()
        t = g["temperature_c"].to_numpy()
        slope = (
            (np.polyfit(t, g["value_true"], 1)[0], np.polyfit(t, g["value_est"], 1)[0])
            if len(t) > 1
            else (np.nan, np.nan)
        )
        rows.append(
            {
                "parameter": name,
                "unit": g["unit_true"].iloc[0],
                "set points": len(g),
                "max |error|": float(np.abs(err).max()),
                "max |error|/sd": float(np.max(np.abs(err) / np.where(sd > 0, sd, np.nan))),
                "truth slope /°C": float(slope[0]),
                "estimated slope /°C": float(slope[1]),
            }
        )
    return pd.DataFrame(rows)


def imu_calibration_stage(cfg: ReproConfig, imu: ImuConfig) -> ImuCalStage:
    """Simulate the plant's multi-position calibration (19 positions and rate tests about
    each axis at 5 set points, ideal turntable; shorter dwells in the quick preset) and fit
    it with :func:`rinscal.calibration.imu.workflow.calibrate_imu`."""
    return _calibrate(imu, cfg.seed + 500, quick=cfg.quick)


def _calibrate(imu: ImuConfig, seed: int, quick: bool) -> ImuCalStage:
    dwell = 60.0 if quick else 120.0
    log, truth, meta = simulate_multiposition(imu, dwell_s=dwell, seed=seed)
    result = calibrate_imu(log, meta)
    thermal = result.calibration.select(SIGNAL_KINDS).relative_to(imu.t_cal_c)
    return ImuCalStage(result, truth, recovery_table(truth, result.estimates), thermal, len(log))


def imu_variant_model(
    imu: ImuConfig, soak: pd.DataFrame, meta: Mapping[str, Any], seed: int, quick: bool = False
) -> FittedModel:
    """The ``regression+sf`` model of one unit (a study's task): its own multi-position
    calibration (seeded by ``seed``), then method 2 on its soak log behind the calibration's
    thermal part."""
    stage = _calibrate(imu, seed, quick)
    return fit(soak, "regression", meta=meta, imu_calibration=stage.thermal_part, seed=seed).model


def imu_thermal_model(
    soak: pd.DataFrame, meta: Mapping[str, Any], stage: ImuCalStage, cfg: ReproConfig
) -> FittedModel:
    """Method 2 fitted on soak output with the IMU calibration's thermal part removed first;
    the model file holds both (``rinscal fit --imu-cal``)."""
    return fit(
        soak, "regression", meta=meta, imu_calibration=stage.thermal_part, seed=cfg.seed
    ).model


#: The verdict on "with it better than without" (:mod:`rinscal.experiments.verdict`) in the
#: words of this table.
_SAVING_WORDS = {
    HOLDS: "holds: the thermal model of scale factor and axes pays",
    REVERSED: "reversed: it costs; without it the error is smaller",
    UNRESOLVED: "no resolved difference: the interval contains zero",
}


def paired_saving_table(
    maxerr: pd.DataFrame, without: str = "regression", with_: str = IMU_VARIANT
) -> pd.DataFrame:
    """What the scale-factor and misalignment thermal model saves, per group of runs:
    the paired difference of the maximum position error ``without − with_`` [nmi] (positive
    = the model helps), its mean and a Student-t interval over the runs of the group.

    Parameters
    ----------
    maxerr : DataFrame
        One row per run with ``experiment, scenario`` and one column per variant [nmi].

    Returns
    -------
    DataFrame
        ``runs``, ``without [nmi]``, ``with [nmi]`` (means), ``saved: mean [nmi]``,
        ``saved: 95 % interval [nmi]`` (empty below the rule's minimum n, said in ``note``),
        ``runs where it helps`` (a count), ``note``.
    """
    rows = []
    for (exp, scen), g in maxerr.groupby(["experiment", "scenario"], sort=False):
        p = paired(g[without], g[with_])  # with − without: negative = it helps
        note = _SAVING_WORDS.get(p.verdict, p.words)
        rows.append(
            {
                "experiment": exp,
                "scenario": scen,
                "runs": p.n,
                "without [nmi]": float(g[without].mean()),
                "with [nmi]": float(g[with_].mean()),
                "saved: mean [nmi]": -p.mean,
                "saved: 95 % interval [nmi]": interval_text(-p.hi, -p.lo, p.mean),
                "runs where it helps": f"{p.better} of {p.n}",
                "note": note,
            }
        )
    return pd.DataFrame(rows)
