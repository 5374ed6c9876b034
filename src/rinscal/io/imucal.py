"""Read an IMU calibration (:class:`rinscal.sensormodel.ImuCalibration`) from any file that
holds one, with what the file says of the unit and the raw units it was fitted in.

Three layouts are read, told apart by their top-level keys:

- a ``rinscal calibrate-imu`` file (``imu.json``), ``{"schema":
  "rinscal.imu-calibration-file/2", "sha256": ..., "imu_calibration": {...}, "input":
  {"units": {...}, "unit_to_si": {...}}, "unit": {...}, ...}``: checksummed
  (:func:`rinscal.io.checksum.payload_sha256` of every key but ``sha256``), with the raw
  units of the multi-position log it was fitted on (``input``) and the unit's identity as
  that log's metadata gave it (``unit``: ``imu``, ``serial``, ``device_ids``). A file of
  schema ``/1`` (written before the checksum existed) is read with a note: nothing shows
  whether it was edited, and it records neither units nor unit;
- a bare serialised calibration, ``{"schema": "rinscal.imu-calibration/1", ...}``
  (:meth:`ImuCalibration.to_dict <rinscal.sensormodel.ImuCalibration.to_dict>`), read with
  the same note;
- a thermal model file (``"format": "rinscal-thermal-model"``, schema version 3 or later)
  whose payload holds an ``imu_calibration`` (written by ``rinscal fit --imu-cal``); its
  checksum is checked and only the calibration (with its input units and unit) is taken.

Every problem raises :class:`~rinscal.errors.ConfigError` naming the file.
"""

from __future__ import annotations

import json
import os
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rinscal.errors import ConfigError
from rinscal.io.checksum import checksum_problem, payload_sha256
from rinscal.schema import CHANNELS
from rinscal.sensormodel import IMU_CALIBRATION_SCHEMA, ImuCalibration

__all__ = [
    "IMU_CALIBRATION_FILE_SCHEMA",
    "IMU_CALIBRATION_FILE_SCHEMA_V1",
    "UNIT_KEYS",
    "ImuCalibrationFile",
    "imu_calibration_file_doc",
    "imu_calibration_file_from_doc",
    "imu_calibration_from_doc",
    "load_imu_calibration",
    "read_imu_calibration",
    "unit_identity",
]

#: Schema tag of a ``rinscal calibrate-imu`` output file (checksummed, with units and unit).
IMU_CALIBRATION_FILE_SCHEMA = "rinscal.imu-calibration-file/2"
#: The tag of the files written before the checksum existed (read with a note).
IMU_CALIBRATION_FILE_SCHEMA_V1 = "rinscal.imu-calibration-file/1"
#: Metadata keys that say which unit a log comes from (``imu``: the IMU's name or preset, as
#: ``rinscal simulate`` writes it; ``serial``: a serial number a user's ``.meta.json`` gives;
#: ``device_ids``: a flight log's sensor ids).
UNIT_KEYS: tuple[str, ...] = ("imu", "serial", "device_ids")
_MODEL_FORMAT = "rinscal-thermal-model"


@dataclass(frozen=True)
class ImuCalibrationFile:
    """An IMU calibration as a file holds it.

    Attributes
    ----------
    calibration : ImuCalibration
    source : str
        The file (or ``"<document>"``).
    input_units : dict of str to str or None, or None
        Raw unit of each channel in the log it was fitted on (``"pulse"``, ``"deg/h"``);
        ``None`` when the file does not record them.
    input_unit_to_si : dict of str to float, or None
        SI value of one raw unit per channel, as recorded (informative: a log at another
        sample rate has other pulse factors).
    unit : dict
        The unit's identity as the calibration log's metadata gave it (keys of
        :data:`UNIT_KEYS`); empty when unknown.
    notes : tuple of str
        What a user should know about the file (no checksum, no units recorded).
    """

    calibration: ImuCalibration
    source: str = "<document>"
    input_units: dict[str, str | None] | None = None
    input_unit_to_si: dict[str, float] | None = None
    unit: dict[str, Any] = field(default_factory=dict)
    notes: tuple[str, ...] = ()


def unit_identity(meta: Mapping[str, Any] | None) -> dict[str, Any]:
    """The keys of :data:`UNIT_KEYS` a log's metadata gives (empty when none)."""
    return {k: meta[k] for k in UNIT_KEYS if meta and meta.get(k) not in (None, "", {})}


def imu_calibration_file_doc(body: Mapping[str, Any]) -> dict[str, Any]:
    """``body`` (an ``imu.json`` without its checksum) with its ``schema`` and ``sha256``.

    Raises
    ------
    ValueError
        A NaN or an infinity in ``body`` (JSON cannot hold them).
    """
    doc = {"schema": IMU_CALIBRATION_FILE_SCHEMA, **{k: v for k, v in body.items()}}
    doc.pop("sha256", None)
    return {**doc, "sha256": payload_sha256(doc)}


def load_imu_calibration(path: str | os.PathLike[str]) -> ImuCalibrationFile:
    """The IMU calibration a file holds, with its units, unit and notes (see the module
    docstring for the layouts).

    Raises
    ------
    ConfigError
        Naming the file: missing, not JSON, not one of the layouts, edited after it was
        written (checksum), a thermal model file without an IMU calibration, or a malformed
        calibration (missing key, unknown parameter, unit other than rinscal's, non-finite
        coefficient).
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

    def _no_constants(name: str) -> Any:
        raise ValueError(f"non-finite number {name}")

    try:
        doc = json.loads(text, parse_constant=_no_constants)
    except json.JSONDecodeError as exc:
        raise ConfigError(
            f"{p}: not valid JSON ({exc.msg} at line {exc.lineno}, column {exc.colno})"
        ) from None
    except (ValueError, RecursionError) as exc:
        raise ConfigError(f"{p}: invalid JSON: {exc}") from None
    return imu_calibration_file_from_doc(doc, str(p))


def read_imu_calibration(path: str | os.PathLike[str]) -> ImuCalibration:
    """The IMU calibration held by a file (:func:`load_imu_calibration`'s calibration; its
    notes are issued as :class:`UserWarning`).

    Raises
    ------
    ConfigError
        As :func:`load_imu_calibration`.
    """
    held = load_imu_calibration(path)
    for note in held.notes:
        warnings.warn(note, UserWarning, stacklevel=2)
    return held.calibration


def imu_calibration_from_doc(doc: Any, source: str = "<document>") -> ImuCalibration:
    """The IMU calibration of a parsed document (:func:`read_imu_calibration`'s layouts).

    Raises
    ------
    ConfigError
        Naming ``source`` and the problem.
    """
    return imu_calibration_file_from_doc(doc, source).calibration


def _checksum(doc: dict[str, Any], covered: Any, source: str, what: str) -> None:
    problem = checksum_problem(doc.get("sha256"), covered)
    if problem is not None:
        raise ConfigError(
            f"{source}: {problem} ({what}); a calibration is not edited by hand: run "
            "rinscal calibrate-imu again"
        )


def _input(d: Any, source: str, where: str) -> tuple[dict[str, str | None], dict[str, float]]:
    if not isinstance(d, dict) or not isinstance(d.get("units"), dict):
        raise ConfigError(f"{source}: {where} must be an object with units and unit_to_si")
    units_in, k_in = d["units"], d.get("unit_to_si") or {}
    if not isinstance(k_in, dict):
        raise ConfigError(f"{source}: {where}.unit_to_si must be an object")
    units: dict[str, str | None] = {}
    factors: dict[str, float] = {}
    for c in CHANNELS:
        u = units_in.get(c)
        if u is not None and not isinstance(u, str):
            raise ConfigError(f"{source}: {where}.units.{c} must be text or null, got {u!r}")
        units[c] = u
        k = k_in.get(c)
        if k is not None:
            if not isinstance(k, int | float) or isinstance(k, bool) or not k > 0:
                raise ConfigError(
                    f"{source}: {where}.unit_to_si.{c} must be a positive number, got {k!r}"
                )
            factors[c] = float(k)
    return units, factors


def imu_calibration_file_from_doc(doc: Any, source: str = "<document>") -> ImuCalibrationFile:
    """The :class:`ImuCalibrationFile` of a parsed document (see :func:`load_imu_calibration`).

    Raises
    ------
    ConfigError
        Naming ``source`` and the problem.
    """
    if not isinstance(doc, dict):
        raise ConfigError(f"{source}: not an IMU calibration (top level is not a JSON object)")
    schema = doc.get("schema")
    unchecked = (
        "written before imu.json carried a checksum and its raw units: nothing shows whether "
        "it was edited, or which units and unit it was fitted on; run rinscal calibrate-imu "
        "again to get both"
    )
    if schema == IMU_CALIBRATION_SCHEMA:
        cal = ImuCalibration.from_dict(doc, source=source)
        return ImuCalibrationFile(
            cal, source, notes=(f"{source}: a bare IMU calibration, {unchecked}",)
        )
    if schema in (IMU_CALIBRATION_FILE_SCHEMA, IMU_CALIBRATION_FILE_SCHEMA_V1):
        if schema == IMU_CALIBRATION_FILE_SCHEMA:
            _checksum(doc, {k: v for k, v in doc.items() if k != "sha256"}, source, schema)
        if not isinstance(doc.get("imu_calibration"), dict):
            raise ConfigError(f"{source}: a {schema} file without its 'imu_calibration' object")
        cal = ImuCalibration.from_dict(doc["imu_calibration"], source=f"{source}: imu_calibration")
        if schema == IMU_CALIBRATION_FILE_SCHEMA_V1:
            return ImuCalibrationFile(cal, source, notes=(f"{source}: {unchecked}",))
        units, factors = _input(doc.get("input"), source, "input")
        unit = doc.get("unit", {})
        if not isinstance(unit, dict):
            raise ConfigError(f"{source}: unit must be an object ({', '.join(UNIT_KEYS)})")
        return ImuCalibrationFile(cal, source, units, factors, dict(unit))
    if doc.get("format") == _MODEL_FORMAT:
        payload = doc.get("payload")
        held = payload.get("imu_calibration") if isinstance(payload, dict) else None
        if held is None:
            raise ConfigError(
                f"{source}: a thermal model file without an IMU calibration (schema version "
                f"{doc.get('schema_version')!r}; fit --imu-cal writes one)"
            )
        _checksum(doc, payload, source, "a thermal model file")
        if not isinstance(held, dict) or not isinstance(held.get("calibration"), dict):
            raise ConfigError(f"{source}: payload.imu_calibration.calibration is not an object")
        cal = ImuCalibration.from_dict(
            held["calibration"], source=f"{source}: payload.imu_calibration.calibration"
        )
        units, factors = _input(held.get("input"), source, "payload.imu_calibration.input")
        unit = held.get("unit") or {}
        return ImuCalibrationFile(
            cal, source, units, factors, dict(unit) if isinstance(unit, dict) else {}
        )
    raise ConfigError(
        f"{source}: not an IMU calibration (schema {schema!r}; expected "
        f"{IMU_CALIBRATION_FILE_SCHEMA!r} from calibrate-imu, {IMU_CALIBRATION_SCHEMA!r}, or a "
        "thermal model file written by fit --imu-cal)"
    )
