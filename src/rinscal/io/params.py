"""The IMU parameter table: one format for the simulator's truth (``cal.params.truth.csv``)
and the calibration's estimate (``imu.params.csv``), so that recovery is one join.

Columns: ``temperature_c`` (the chamber set point [°C], written the same way by both),
``parameter`` (a name of :data:`rinscal.sensormodel.PARAMETERS`, e.g. ``gyro_sf_x``),
``value`` and ``sd`` (its standard deviation; 0 for a truth) in ``unit`` (the parameter's
unit: deg/h, ug, ppm, ppm/(deg/s), ug/g^2, arcsec). One row per set point and parameter.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from rinscal.errors import ConfigError, LogError
from rinscal.io.atomic import write_atomic
from rinscal.sensormodel import parameter_spec

__all__ = [
    "PARAMS_COLUMNS",
    "TRUTH_SUFFIX",
    "check_params_table",
    "params_path",
    "read_params",
    "write_params",
]

#: Columns of a parameter table, in order.
PARAMS_COLUMNS = ("temperature_c", "parameter", "value", "sd", "unit")

#: The simulator's truth table beside a multiposition log (:func:`params_path`'s suffix).
TRUTH_SUFFIX = ".params.truth.csv"


def params_path(path: str | os.PathLike[str], suffix: str = ".params.csv") -> Path:
    """The table beside ``path``: ``cal.parquet`` → ``cal.params.truth.csv`` with
    ``suffix=".params.truth.csv"``, ``imu.json`` → ``imu.params.csv``."""
    p = Path(path)
    return p.with_name(p.name.split(".")[0] + suffix) if p.name else p


def check_params_table(df: pd.DataFrame, source: str = "<table>") -> pd.DataFrame:
    """Validate a parameter table: columns, known parameters, their units, finite numbers,
    one row per (temperature, parameter). Returns it with ``temperature_c``, ``value`` and
    ``sd`` as floats; raises :class:`LogError` naming ``source``, row and column."""
    missing = [c for c in PARAMS_COLUMNS if c not in df.columns]
    if missing:
        raise LogError(f"{source}: missing column(s) {missing}; need {list(PARAMS_COLUMNS)}")
    out = df.copy()
    for col in ("temperature_c", "value", "sd"):
        num = pd.to_numeric(out[col], errors="coerce")
        bad = np.flatnonzero(~np.isfinite(num.to_numpy(dtype=float)))
        if bad.size:
            raise LogError(
                f"{source}: row {int(bad[0]) + 2}, column {col}: {out[col].iloc[bad[0]]!r} is "
                "not a finite number"
            )
        out[col] = num.astype(float)
    for row, (name, unit) in enumerate(zip(out["parameter"], out["unit"], strict=True)):
        try:
            spec = parameter_spec(str(name))
        except ConfigError as exc:
            raise LogError(f"{source}: row {row + 2}, column parameter: {exc}") from None
        if str(unit) != spec.unit:
            raise LogError(
                f"{source}: row {row + 2}: {name} is in {unit!r}; its unit is {spec.unit!r}"
            )
    dup = out.duplicated(["temperature_c", "parameter"])
    if dup.any():
        row = int(np.flatnonzero(dup.to_numpy())[0])
        raise LogError(
            f"{source}: row {row + 2}: {out['parameter'].iloc[row]} at "
            f"{out['temperature_c'].iloc[row]} °C appears twice"
        )
    return out


def write_params(df: pd.DataFrame, path: str | os.PathLike[str]) -> Path:
    """Write a parameter table atomically as CSV (columns :data:`PARAMS_COLUMNS`, float
    values in full precision)."""
    table = check_params_table(df, str(path))[list(PARAMS_COLUMNS)]
    p = Path(path)
    write_atomic(p, lambda tmp: table.to_csv(tmp, index=False, float_format="%.10g"))
    return p


def read_params(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read and validate a parameter table written by :func:`write_params` (or by hand)."""
    p = Path(path)
    try:
        df = pd.read_csv(p, dtype={"parameter": str, "unit": str})
    except (OSError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise LogError(f"{p}: cannot read the parameter table ({exc})") from None
    return check_params_table(df, str(p))
