"""Read an IMU calibration (:class:`rinscal.sensormodel.ImuCalibration`) from any file that
holds one.

Three layouts are read, told apart by their top-level keys:

- a ``rinscal calibrate-imu`` file, ``{"schema": "rinscal.imu-calibration-file/1",
  "imu_calibration": {...}, ...}``;
- a bare serialised calibration, ``{"schema": "rinscal.imu-calibration/1", ...}``
  (:meth:`ImuCalibration.to_dict <rinscal.sensormodel.ImuCalibration.to_dict>`);
- a thermal model file (``"format": "rinscal-thermal-model"``, schema version 3 or later)
  whose payload holds an ``imu_calibration`` (written by ``rinscal fit --imu-cal``). Only the
  calibration is taken from it; load the model itself with
  :meth:`rinscal.calibration.modelfile.ThermalModelFile.load`, which also checks its checksum.

Every problem raises :class:`~rinscal.errors.ConfigError` naming the file.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from rinscal.errors import ConfigError
from rinscal.sensormodel import IMU_CALIBRATION_SCHEMA, ImuCalibration

__all__ = ["IMU_CALIBRATION_FILE_SCHEMA", "imu_calibration_from_doc", "read_imu_calibration"]

#: Schema tag of a ``rinscal calibrate-imu`` output file.
IMU_CALIBRATION_FILE_SCHEMA = "rinscal.imu-calibration-file/1"
_MODEL_FORMAT = "rinscal-thermal-model"


def read_imu_calibration(path: str | os.PathLike[str]) -> ImuCalibration:
    """The IMU calibration held by a file (see the module docstring for the layouts).

    Parameters
    ----------
    path : path-like
        A ``calibrate-imu`` output, a bare IMU calibration, or a thermal model file with one.

    Returns
    -------
    ImuCalibration

    Raises
    ------
    ConfigError
        Naming the file: missing, not JSON, not one of the layouts, a thermal model file
        without an IMU calibration, or a malformed calibration (unknown parameter, unit other
        than rinscal's, non-finite coefficient).
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"{p}: no such IMU calibration file") from None
    except IsADirectoryError:
        raise ConfigError(f"{p}: is a folder, not an IMU calibration file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{p}: cannot read IMU calibration file: {exc}") from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ConfigError(
            f"{p}: not valid JSON ({exc.msg} at line {exc.lineno}, column {exc.colno})"
        ) from None
    return imu_calibration_from_doc(doc, str(p))


def imu_calibration_from_doc(doc: Any, source: str = "<document>") -> ImuCalibration:
    """The IMU calibration of a parsed document (:func:`read_imu_calibration`'s layouts).

    Raises
    ------
    ConfigError
        Naming ``source`` and the problem.
    """
    if not isinstance(doc, dict):
        raise ConfigError(f"{source}: not an IMU calibration (top level is not a JSON object)")
    schema = doc.get("schema")
    if schema == IMU_CALIBRATION_SCHEMA:
        return ImuCalibration.from_dict(doc, source=source)
    if schema == IMU_CALIBRATION_FILE_SCHEMA:
        if not isinstance(doc.get("imu_calibration"), dict):
            raise ConfigError(f"{source}: a {schema} file without its 'imu_calibration' object")
        return ImuCalibration.from_dict(doc["imu_calibration"], source=f"{source}: imu_calibration")
    if doc.get("format") == _MODEL_FORMAT:
        payload = doc.get("payload")
        held = payload.get("imu_calibration") if isinstance(payload, dict) else None
        if held is None:
            raise ConfigError(
                f"{source}: a thermal model file without an IMU calibration (schema version "
                f"{doc.get('schema_version')!r}; fit --imu-cal writes one)"
            )
        if not isinstance(held, dict) or not isinstance(held.get("calibration"), dict):
            raise ConfigError(f"{source}: payload.imu_calibration.calibration is not an object")
        return ImuCalibration.from_dict(
            held["calibration"], source=f"{source}: payload.imu_calibration.calibration"
        )
    raise ConfigError(
        f"{source}: not an IMU calibration (schema {schema!r}; expected "
        f"{IMU_CALIBRATION_FILE_SCHEMA!r} from calibrate-imu, {IMU_CALIBRATION_SCHEMA!r}, or a "
        "thermal model file written by fit --imu-cal)"
    )
