"""The IMU-calibration step of a thermal model file: raw output to the thermal model's input.

A model file (:mod:`rinscal.calibration.modelfile`, schema version 3) may hold an IMU
calibration (:class:`rinscal.sensormodel.ImuCalibration`: scale factors, nonlinear terms and
misalignments as laws in temperature) beside its thermal bias model. Compensation then runs
in one order, :data:`IMU_ORDER`, written into the file too:

1. raw output in the log's units × ``unit_to_si`` → SI (pulses by their nominal weight);
2. the inverse sensor model at each channel's inner temperature
   (:meth:`ImuCalibration.correct <rinscal.sensormodel.ImuCalibration.correct>` with
   ``with_bias=False``: the thermal model holds the whole bias);
3. SI → deg/h and µg (:data:`PHYSICAL_UNITS`), the unit the thermal model was fitted in;
4. the thermal bias model, ``y − (f(T, Ṫ, ΔT) − r)``.

:class:`ImuStage` is steps 1-3, evaluated with numpy alone.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rinscal import units
from rinscal.calibration._modelcheck import CHANNELS, exact, finite
from rinscal.errors import ConfigError
from rinscal.sensormodel import ImuCalibration

__all__ = ["IMU_ORDER", "PHYSICAL_TO_SI", "PHYSICAL_UNITS", "ImuStage"]

#: The order in which a model file that holds an IMU calibration is applied (also written in
#: the file, ``imu_calibration.order``).
IMU_ORDER: tuple[str, ...] = (
    "raw output in the log's units x imu_calibration.input.unit_to_si -> SI (pulses by their "
    "nominal weight)",
    "inverse sensor model at each channel's inner temperature: nonlinear scale-factor terms and "
    "scale factor (fixed-point iteration per channel), then misalignment (solve I + M per "
    "triad); the calibration's biases stay in",
    "SI -> deg/h (gyros) and ug (accelerometers), the thermal model's unit",
    "thermal bias model: y - (f(T, Tdot, dT) - static_reference), in deg/h and ug",
)
#: Unit of the thermal model's input (and of the compensated output) behind an IMU calibration.
PHYSICAL_UNITS: dict[str, str] = {"gyro": "deg/h", "accel": "ug"}
#: SI value of one :data:`PHYSICAL_UNITS` unit, per channel in :data:`rinscal.schema.CHANNELS`.
PHYSICAL_TO_SI = np.array([units.DPH_TO_RPS] * 3 + [units.UG_TO_MPS2] * 3)


@dataclass(frozen=True)
class ImuStage:
    """The IMU calibration a model file applies before its thermal bias model.

    Attributes
    ----------
    calibration : ImuCalibration
        Scale factors, nonlinear terms and misalignments (and biases, not applied: the
        thermal model holds the whole bias) as laws in temperature.
    input_units : dict of str to str or None
        Unit of each raw channel in the logs the model applies to (``"pulse"``, ``"deg/h"``).
    input_unit_to_si : dict of str to float
        SI value of one raw unit per channel [rad/s or m/s² per unit] (for pulses, counts per
        sample: the nominal pulse weight over the sample interval).
    unit : dict
        The unit the calibration was made on, as its log's metadata named it (``imu``,
        ``serial``, ``device_ids``; :data:`rinscal.io.imucal.UNIT_KEYS`); empty when unknown.
    """

    calibration: ImuCalibration
    input_units: dict[str, str | None]
    input_unit_to_si: dict[str, float]
    unit: dict[str, Any] = field(default_factory=dict)

    @property
    def needs_rate(self) -> bool:
        """Whether some law depends on the temperature rate (a ramp calibration)."""
        return bool(self.calibration.rate_coefs)

    def correct_si(self, raw: Any, temp_c: Any, tdot_c_per_min: Any = None) -> np.ndarray:
        """Steps 1-2 of :data:`IMU_ORDER`: raw output → true rate and specific force plus bias.

        Parameters
        ----------
        raw : array_like, shape (n, 6) [input units]
            Raw output of gyro x..z and accel x..z.
        temp_c : array_like, shape (n, 6) [°C]
            Inner temperature of each channel.
        tdot_c_per_min : array_like, shape (n, 6), optional [°C/min]
            Its rate (used by laws fitted on a ramp).

        Returns
        -------
        ndarray, shape (n, 6) [rad/s, m/s²]
        """
        k = np.array([self.input_unit_to_si[c] for c in CHANNELS])
        return self.inverse_si(np.asarray(raw, dtype=np.float64) * k, temp_c, tdot_c_per_min)

    def inverse_si(self, y_si: Any, temp_c: Any, tdot_c_per_min: Any = None) -> np.ndarray:
        """Step 2 of :data:`IMU_ORDER` alone, on output already in SI (a recording read in
        SI increments): :meth:`ImuCalibration.correct
        <rinscal.sensormodel.ImuCalibration.correct>` with ``with_bias=False``.

        Parameters
        ----------
        y_si : array_like, shape (n, 6) [rad/s, m/s²]
            Output of gyro x..z and accel x..z.
        temp_c, tdot_c_per_min
            As :meth:`correct_si`.

        Returns
        -------
        ndarray, shape (n, 6) [rad/s, m/s²]
        """
        return self.calibration.correct(y_si, temp_c, tdot_c_per_min, with_bias=False)

    def physical(self, raw: Any, temp_c: Any, tdot_c_per_min: Any = None) -> np.ndarray:
        """Steps 1-3 of :data:`IMU_ORDER`: the thermal model's input, in deg/h and µg.

        Parameters and shapes as :meth:`correct_si`; the result is in :data:`PHYSICAL_UNITS`.
        """
        return self.correct_si(raw, temp_c, tdot_c_per_min) / PHYSICAL_TO_SI

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form (the model file's ``imu_calibration``; ``unit`` only when known)."""
        out = {
            "order": list(IMU_ORDER),
            "input": {
                "units": {c: self.input_units.get(c) for c in CHANNELS},
                "unit_to_si": {c: float(self.input_unit_to_si[c]) for c in CHANNELS},
            },
            "output_units": dict(PHYSICAL_UNITS),
            "calibration": self.calibration.to_dict(),
        }
        if self.unit:
            out["unit"] = dict(self.unit)
        return out

    @classmethod
    def from_dict(cls, d: Any) -> ImuStage:
        """Validate the model file's ``imu_calibration``; :class:`ValueError` naming the key."""
        keys = ("order", "input", "output_units", "calibration")
        exact(
            d, (*keys, "unit") if isinstance(d, dict) and "unit" in d else keys, "imu_calibration"
        )
        unit = d.get("unit", {})
        if not isinstance(unit, dict):
            raise ValueError("imu_calibration.unit must be an object")
        if not isinstance(d["order"], list) or not all(isinstance(v, str) for v in d["order"]):
            raise ValueError("imu_calibration.order must be a list of text")
        if d["output_units"] != PHYSICAL_UNITS:
            raise ValueError(f"imu_calibration.output_units must be {PHYSICAL_UNITS}")
        exact(d["input"], ("units", "unit_to_si"), "imu_calibration.input")
        got_units, got_k = d["input"]["units"], d["input"]["unit_to_si"]
        exact(got_units, CHANNELS, "imu_calibration.input.units")
        exact(got_k, CHANNELS, "imu_calibration.input.unit_to_si")
        unit_map: dict[str, str | None] = {}
        k_map: dict[str, float] = {}
        for c in CHANNELS:
            k = finite(got_k[c], f"imu_calibration.input.unit_to_si.{c}", True, False)
            u = got_units[c]
            if u is not None:
                try:
                    units.check_sensor_unit(c.partition("_")[0], str(u), k)
                except ValueError as exc:
                    raise ValueError(f"imu_calibration.input.units.{c}: {exc}") from None
            unit_map[c], k_map[c] = (None if u is None else str(u)), float(k or 0.0)
        try:
            cal = ImuCalibration.from_dict(d["calibration"], source="imu_calibration.calibration")
        except ConfigError as exc:
            raise ValueError(str(exc)) from None
        return cls(cal, unit_map, k_map, dict(unit))
